// SceneLights: building every light of a scene, the choice by power (and uniform), the plan's switches, and an end
// -to-end check that sample_li, pdf_li, Le and pmf agree: one-sample MIS (light sampling + cosine sampling, balance
// heuristic) over a scene with every kind of non-delta light reproduces the analytic irradiance.
#include "bakers/scene/light_sampler.h"

#include <gtest/gtest.h>

#include <cmath>

#include "bakers/scene/area_lights.h"
#include "bakers/scene/polygon_irradiance.h"
#include "bakers/scene/punctual_lights.h"
#include "tests/scene/light_test_util.h"
#include "tests/support/tolerance.h"

namespace kiln::scene {
namespace {

constexpr double kDeg = kPi / 180.0;

// A box floor 0..2 in x and z with an emissive quad above it (two triangles, facing down), and one light of each
// kind, and a constant sky.
Scene every_light_scene() {
  Scene s;
  s.materials.resize(2);
  s.materials[1].emission = Rgb{3, 3, 3};
  Mesh floor;
  floor.name = "floor";
  floor.positions = {{0, 0, 0}, {2, 0, 0}, {2, 0, 2}, {0, 0, 2}};
  floor.indices = {0, 2, 1, 0, 3, 2};
  Mesh lamp;
  lamp.name = "lamp";
  lamp.positions = {{0.5, 2, 0.5}, {1.5, 2, 0.5}, {1.5, 2, 1.5}, {0.5, 2, 1.5}};
  lamp.indices = {0, 1, 2, 0, 2, 3};  // (1,0,0) × (1,0,1) = (0,−1,0): facing down
  lamp.material = {1, 1};
  s.meshes = {floor, lamp};
  Instance a, b;
  a.mesh = 0;
  b.mesh = 1;
  s.instances = {a, b};
  Light point;
  point.type = LightShape::point;
  point.position = {1, 1, 1};
  point.color = Rgb{10};
  Light spot = point;
  spot.type = LightShape::spot;
  spot.inner_cone = 0.2;
  spot.outer_cone = 0.4;
  Light sun;
  sun.type = LightShape::directional;
  sun.direction = {0.2, -1, 0.1};
  sun.color = Rgb{100};
  sun.angular_diameter = 10 * kDeg;
  Light rect;
  rect.type = LightShape::rect;
  rect.position = {1, 1.5, 1};
  rect.u_axis = {0.5, 0, 0};
  rect.v_axis = {0, 0, 0.25};
  rect.color = Rgb{20};
  Light disk = rect;
  disk.type = LightShape::disk;
  disk.position = {0.3, 1.2, 1.4};
  disk.radius = 0.2;
  Light black = point;
  black.color = Rgb{0};
  s.lights = {point, spot, sun, rect, disk, black};
  s.environment.constant = Rgb{0.5};
  return s;
}

TEST(SceneLights, BuildsEveryLightAndChoosesByPower) {
  const Scene scene = every_light_scene();
  const SceneLights lights(scene);
  ASSERT_EQ(lights.size(), 8);  // 6 explicit, the emissive triangles, the environment
  EXPECT_EQ(lights.light(0).kind(), LightSamplerKind::point);
  EXPECT_EQ(lights.light(1).kind(), LightSamplerKind::spot);
  EXPECT_EQ(lights.light(2).kind(), LightSamplerKind::sun);
  EXPECT_EQ(lights.light(3).kind(), LightSamplerKind::rect);
  EXPECT_EQ(lights.light(4).kind(), LightSamplerKind::disk);
  ASSERT_NE(lights.emissive(), nullptr);
  EXPECT_EQ(lights.emissive()->size(), 2);
  ASSERT_NE(lights.environment(), nullptr);
  EXPECT_EQ(lights.escape_lights(), (std::vector<int>{2, 7}));  // the sun disc and the environment
  // The floor spans (0,0,0)–(2,2,2) with the lamp: radius √3.
  EXPECT_TRUE(test::close(lights.scene_radius(), std::sqrt(3.0), 1e-15));
  // pmf ∝ luminance(power); the black light is never chosen.
  double total = 0;
  for (int i = 0; i < lights.size(); ++i) total += luminance(lights.light(i).power(lights.scene_radius()));
  double sum = 0;
  for (int i = 0; i < lights.size(); ++i) {
    const double expected = luminance(lights.light(i).power(lights.scene_radius())) / total;
    EXPECT_TRUE(test::close(lights.pmf(i), expected, 1e-14)) << i;
    EXPECT_EQ(lights.pmf(&lights.light(i)), lights.pmf(i));
    sum += lights.pmf(i);
  }
  EXPECT_NEAR(sum, 1.0, 1e-15);
  EXPECT_EQ(lights.pmf(5), 0.0);
  // Sampling follows the pmf (χ², 1% level) and never picks the black light.
  std::vector<double> observed(lights.size(), 0), expected(lights.size(), 0);
  Pcg32 rng(5);
  const int n = 100000;
  for (int k = 0; k < n; ++k) {
    const auto c = lights.sample(rng.uniform());
    ASSERT_TRUE(c);
    ASSERT_NE(c->index, 5);
    ASSERT_EQ(c->light, &lights.light(c->index));
    ASSERT_EQ(c->pmf, lights.pmf(c->index));
    ASSERT_TRUE(c->u_remapped >= 0 && c->u_remapped < 1);
    observed[c->index] += 1;
  }
  for (int i = 0; i < lights.size(); ++i) expected[i] = n * lights.pmf(i);
  const auto r = test::pearson_chi2(observed, expected);
  EXPECT_GT(r.p_value, 0.01) << r.worst;
}

TEST(SceneLights, UniformChoiceAndThePlansSwitches) {
  const Scene scene = every_light_scene();
  LightSamplingOptions o;
  o.choice = LightChoice::uniform;
  const SceneLights uniform(scene, o);
  for (int i = 0; i < uniform.size(); ++i) EXPECT_DOUBLE_EQ(uniform.pmf(i), i == 5 ? 0.0 : 1.0 / 7);
  // Turning strategies off keeps the lights (their Le is still seen by BSDF rays) with pmf 0.
  o = {};
  o.environment = false;
  o.emissive_triangles = false;
  o.point_lights = false;
  o.environment_importance_map = false;
  const SceneLights pruned(scene, o);
  ASSERT_EQ(pruned.size(), 8);
  EXPECT_EQ(pruned.pmf(pruned.environment()), 0.0);
  EXPECT_EQ(pruned.pmf(pruned.emissive()), 0.0);
  EXPECT_EQ(pruned.pmf(0), 0.0);
  EXPECT_GT(pruned.pmf(1), 0.0);
  EXPECT_FALSE(pruned.environment()->importance_sampled());
  // Nothing but black lights: no choice at all.
  Scene dark;
  Light black;
  black.color = Rgb{0};
  dark.lights = {black};
  const SceneLights none(dark);
  EXPECT_FALSE(none.sample(0.5));
  EXPECT_EQ(none.pmf(0), 0.0);
  EXPECT_EQ(none.environment(), nullptr);
  EXPECT_EQ(none.emissive(), nullptr);
  EXPECT_DOUBLE_EQ(scene_bounding_radius(dark), 1.0);  // no geometry: 1
}

// The irradiance at p (normal +Y) from every non-delta light, by one-sample MIS per strategy with the balance
// heuristic: for each light l the integrand Le_l cos is estimated from a light sample (density pmf_l pdf_l) and from
// a cosine sample (density cos/π), each weighted by its share of the summed densities. Lights do not occlude each
// other here (the reference adds their irradiances). A wrong pdf_li, Le or pmf biases this estimate.
TEST(SceneLights, MultipleImportanceSamplingReproducesTheAnalyticIrradiance) {
  Scene scene = every_light_scene();
  scene.lights = {scene.lights[2], scene.lights[3], scene.lights[4]};  // sun disc, rect, disk
  // The sky: 1 above the horizon, 0 below, as an image (importance sampled): E = π for n = +Y, less the bilinear
  // blur of the horizon, −π δ²/6 with δ = π/256 (see environment_light_test).
  scene.environment = {};
  scene.environment.width = 256;
  scene.environment.height = 128;
  for (int y = 0; y < 128; ++y)
    for (int x = 0; x < 256; ++x) scene.environment.equirect.push_back(Rgb{y < 64 ? 1.0 : 0.0});
  const SceneLights lights(scene);
  ASSERT_EQ(lights.size(), 5);
  const Vec3 p{1.1, 0.0, 0.9}, n{0, 1, 0};
  const Frame frame = Frame::from_normal(n);

  // Analytic references (exact up to the sky's blur).
  const auto& rect = static_cast<const RectLight&>(lights.light(1));
  const double delta = kPi / 256;
  double exact = kPi - kPi * delta * delta / 6;
  exact += 100 * dot(normalize(Vec3{-0.2, 1, -0.1}), n);  // the sun: E cos θ (its disc is above the horizon)
  exact += 20 * polygon_projected_solid_angle({rect.corner(0), rect.corner(1), rect.corner(2), rect.corner(3)}, p, n);
  std::vector<Vec3> disk_in, disk_out;  // the disk between its inscribed and circumscribed 512-gons
  for (int k = 0; k < 512; ++k) {
    const double phi = 2 * kPi * k / 512;
    disk_in.push_back(Vec3{0.3, 1.2, 1.4} + Vec3{std::cos(phi), 0, std::sin(phi)} * 0.2);
    disk_out.push_back(Vec3{0.3, 1.2, 1.4} + Vec3{std::cos(phi), 0, std::sin(phi)} * (0.2 / std::cos(kPi / 512)));
  }
  const double disk_lo = 20 * polygon_projected_solid_angle(disk_in, p, n);
  const double disk_hi = 20 * polygon_projected_solid_angle(disk_out, p, n);
  for (int t = 0; t < lights.emissive()->size(); ++t) {
    const auto& tri = lights.emissive()->triangle(t);
    exact += 3 * polygon_projected_solid_angle({tri.p0, tri.p1, tri.p2}, p, n);
  }

  // What a ray from p along w sees of light l: Le and where (the analytic shapes by intersect, the triangles by
  // Möller–Trumbore, the sun and sky for every ray: no occlusion).
  const auto reach = [&](int l, const Vec3& w, LightHit& hit) -> bool {
    const LightSource& light = lights.light(l);
    if (light.kind() == LightSamplerKind::emissive_triangles) {
      hit = test::intersect_triangles(*lights.emissive(), p, w);
      return hit.triangle >= 0;
    }
    if (light.is_infinite()) return true;
    const auto h = light.intersect(p, w, kInfinity);
    if (h) hit = *h;
    return h.has_value();
  };

  Pcg32 rng(2024);
  const int n_samples = 400000;
  double sum = 0, sum2 = 0;
  for (int k = 0; k < n_samples; ++k) {
    double f = 0;
    // Light sampling.
    if (const auto c = lights.sample(rng.uniform())) {
      const Point2 u{rng.uniform(), rng.uniform()};
      if (const auto s = c->light->sample_li(p, n, u)) {
        const double cos_theta = dot(s->wi, n);
        if (cos_theta > 0) {
          const double p_light = c->pmf * s->pdf, p_bsdf = cos_theta * kInvPi;
          f += s->Li.r * cos_theta / p_light * (p_light / (p_light + p_bsdf));
        }
      }
    } else {
      rng.uniform();
      rng.uniform();
    }
    // Cosine sampling: every light the ray reaches.
    const Vec3 w = frame.from_local(sample_cosine_hemisphere({rng.uniform(), rng.uniform()}));
    const double cos_theta = dot(w, n);
    if (cos_theta > 0) {
      const double p_bsdf = cos_theta * kInvPi;
      for (int l = 0; l < lights.size(); ++l) {
        LightHit hit;
        if (!reach(l, w, hit)) continue;
        const double le = lights.light(l).Le(p, w, hit).r;
        if (le == 0) continue;
        const double p_light = lights.pmf(l) * lights.light(l).pdf_li(p, n, w, hit);
        f += le * cos_theta / p_bsdf * (p_bsdf / (p_bsdf + p_light));
      }
    }
    ASSERT_TRUE(std::isfinite(f));
    sum += f;
    sum2 += f * f;
  }
  const double mean = sum / n_samples;
  const double se = std::sqrt((sum2 / n_samples - mean * mean) / (n_samples - 1));
  // 5 standard errors, the disk's polygon bracket and the sky's blur bound (both ~1e-4 relative of their parts).
  EXPECT_GT(mean, exact + disk_lo - 5 * se) << "standard error " << se;
  EXPECT_LT(mean, exact + disk_hi + 5 * se) << "standard error " << se;
}

}  // namespace
}  // namespace kiln::scene
