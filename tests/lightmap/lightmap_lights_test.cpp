// Every light type of the lightmap baker against an analytic answer at every texel of a floor (albedo 0, so all
// light is direct): spot (glTF's falloff), disk (on-axis closed form and Lambert's formula), sun with a disc,
// emissive triangles, environment images (with rotation) and two lights at once.
//
// The reference per texel is the analytic field averaged over the very sample points and weights the baker's
// rasterizer gives the texel (test::texel_means): a noise-free bake would store exactly that. What remains is the
// estimator's noise (bounded by 6 of the texel's own estimated standard errors: ≈ 2e-9 two-sided chance per texel
// under normality, a few hundred texels per test) and float storage (6e-8 relative; 1e-6 is allowed for the sums).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "bakers/lightmap/lightmap_bake.h"
#include "bakers/math/constants.h"
#include "bakers/scene/polygon_irradiance.h"
#include "tests/support/test_scenes.h"

namespace kiln::lightmap {
namespace {

using test::exr_output;
using test::lambert_material;
using test::lightmap_input;
using test::texel_means;

constexpr int kW = 16;
constexpr double kStorage = 1e-6;  // float storage and summation, relative

scene::Scene black_floor() {
  scene::Scene s;
  s.materials.push_back(lambert_material("black", 0.0));
  test::add_floor(s, 2.0, 0);
  return s;
}

// A square of half-side h centred at c, facing `normal` (its own mesh and lightmap `name`).
int add_facing_quad(scene::Scene& s, const std::string& name, Vec3 c, Vec3 normal, double h, uint32_t material) {
  const Vec3 n = normalize(normal);
  const Vec3 t = normalize(std::abs(n.y) < 0.9 ? cross(Vec3{0, 1, 0}, n) : cross(Vec3{1, 0, 0}, n));
  const Vec3 b = cross(n, t);  // t × b = n: counter-clockwise seen from the front
  return test::add_quad(s, name, c - t * h - b * h, c + t * h - b * h, c + t * h + b * h, c - t * h + b * h, material,
                        4);
}

// Compares lightmap `map` of a bake with `expected` per valid texel: |E − expected| ≤ kEstimatedSigmas σ̂ + rel·expected
// + abs. Returns the number of texels compared.
int expect_matches(const LightmapBakeResult& r, const std::string& map, const std::vector<double>& expected, double rel,
                   double abs, const std::string& what) {
  const image::FloatImage E = exr_output(r, map + "_irradiance.exr"), err = exr_output(r, map + "_error.exr");
  int n = 0;
  for (int y = 0; y < E.height; ++y) {
    for (int x = 0; x < E.width; ++x) {
      const double want = expected[static_cast<size_t>(y) * E.width + x];
      if (std::isnan(want)) continue;
      ++n;
      for (int c = 0; c < 3; ++c) {
        const double got = E.at(x, y, c);
        EXPECT_TRUE(std::isfinite(got)) << what << " texel " << x << "," << y;
        EXPECT_NEAR(got, want, test::kEstimatedSigmas * err.at(x, y, 0) * want + rel * want + abs)
            << what << " texel " << x << "," << y << " channel " << c;
      }
    }
  }
  return n;
}

// glTF KHR_lights_punctual's spot falloff, written from the extension's text: the square of the linear ramp in cos
// between the outer and the inner cone.
double khr_spot_falloff(double cos_angle, double inner, double outer) {
  const double t = (cos_angle - std::cos(outer)) / (std::cos(inner) - std::cos(outer));
  const double c = std::clamp(t, 0.0, 1.0);
  return c * c;
}

// Spot: E = I a(cos) cos θ / r². Delta light, albedo 0, one light: the estimator has no variance, so only float
// storage remains; texels span the full cone, the ramp and the dark outside.
TEST(LightmapLights, SpotLightFollowsTheGltfFalloff) {
  scene::Scene s = black_floor();
  scene::Light l;
  l.type = scene::LightShape::spot;
  l.position = {0.2, 1.2, -0.1};
  l.direction = normalize(Vec3{0.2, -1, 0.1});
  l.inner_cone = 0.25;
  l.outer_cone = 0.55;
  l.color = Rgb{20.0};
  s.lights.push_back(l);
  const auto expected = texel_means(s, "floor", kW, [&](const Vec3& p, const Vec3& n) {
    const Vec3 d = l.position - p;
    const double r = length(d);
    const Vec3 wi = d / r;
    return l.color.r * khr_spot_falloff(dot(-wi, l.direction), l.inner_cone, l.outer_cone) * std::max(0.0, dot(n, wi)) /
           (r * r);
  });
  const auto lit = std::count_if(expected.begin(), expected.end(), [](double e) { return e > 0; });
  ASSERT_GT(lit, 20) << "the cone and its ramp cover texels";
  ASSERT_GT(static_cast<long>(expected.size()) - lit, 20) << "some texels lie outside the outer cone";
  const LightmapBakeResult r = bake_lightmaps(lightmap_input(s, kW, 0.01));
  EXPECT_EQ(expect_matches(r, "floor", expected, kStorage, 1e-9, "spot"), kW * kW);
}

// Disk: the exact irradiance of an equal-area 256-gon (Lambert's formula), checked first against the disk's on-axis
// closed form π L r²/(r² + h²). The equal-area polygon differs from the disk by the sliver between them, whose
// first-order effect on E cancels (equal area, spread evenly around the rim): ≤ 1e-5 relative here, so 1e-4 is
// allowed for the reference; the rest is the estimator's noise (area sampling combined with cosine sampling).
TEST(LightmapLights, DiskLightMatchesLambertsFormulaAndTheOnAxisClosedForm) {
  scene::Scene s = black_floor();
  scene::Light l;
  l.type = scene::LightShape::disk;
  l.position = {0.1, 0.8, 0.2};
  l.direction = {0, -1, 0};
  l.radius = 0.3;
  l.color = Rgb{5.0};
  s.lights.push_back(l);
  constexpr int kSides = 256;
  // Equal area: N/2 R² sin(2π/N) = π r².
  const double R = l.radius * std::sqrt(kPi / (0.5 * kSides * std::sin(2 * kPi / kSides)));
  std::vector<Vec3> polygon;
  for (int i = 0; i < kSides; ++i) {
    const double phi = 2 * kPi * i / kSides;
    polygon.push_back(l.position + Vec3{R * std::cos(phi), 0, R * std::sin(phi)});
  }
  auto disk_E = [&](const Vec3& p, const Vec3& n) {
    return l.color.r * scene::polygon_projected_solid_angle(polygon, p, n);
  };
  const double h = l.position.y, r2 = l.radius * l.radius;
  const Vec3 under{l.position.x, 0, l.position.z};
  EXPECT_NEAR(disk_E(under, {0, 1, 0}), kPi * l.color.r * r2 / (r2 + h * h), 1e-5 * kPi * l.color.r * r2 / (r2 + h * h))
      << "the polygon reference reproduces the on-axis closed form";
  const auto expected = texel_means(s, "floor", kW, disk_E);
  LightmapBakeInput in = lightmap_input(s, kW, 0.01);
  in.min_samples = 64;  // the adaptive stop needs a sound variance estimate first (see lightmap_bake.cpp)
  const LightmapBakeResult r = bake_lightmaps(in);
  EXPECT_EQ(expect_matches(r, "floor", expected, 1e-4, 1e-9, "disk"), kW * kW);
}

// The sun with a disc of angular diameter 0.1 rad wholly above every texel's horizon: E = E_n cos θ_c exactly (the
// projected solid angle of a spherical cap above the horizon is π sin²θ_max cos θ_c). Noise only from cos θ varying
// across the disc.
TEST(LightmapLights, SunDiscGivesECosTheta) {
  scene::Scene s = black_floor();
  scene::Light sun;
  sun.type = scene::LightShape::directional;
  sun.direction = normalize(Vec3{0.3, -1, 0.2});
  sun.angular_diameter = 0.1;
  sun.color = Rgb{2.0};
  s.lights.push_back(sun);
  const auto expected =
      texel_means(s, "floor", kW, [&](const Vec3&, const Vec3& n) { return sun.color.r * dot(n, -sun.direction); });
  const LightmapBakeResult r = bake_lightmaps(lightmap_input(s, kW, 0.005));
  EXPECT_EQ(expect_matches(r, "floor", expected, kStorage, 1e-9, "sun disc"), kW * kW);
}

// A one-sided emissive quad facing the floor is a rectangle light made of two emissive triangles: Lambert's formula.
TEST(LightmapLights, EmissiveTrianglesMatchLambertsFormula) {
  scene::Scene s = black_floor();
  s.materials.push_back(lambert_material("glow", 0.0, Rgb{10.0}));
  const Vec3 q[4] = {{-0.1, 1, -0.3}, {0.5, 1, -0.3}, {0.5, 1, 0.1}, {-0.1, 1, 0.1}};  // CCW from below: faces −Y
  const int mesh = test::add_quad(s, "lamp", q[0], q[1], q[2], q[3], 1, 1);
  s.instances[mesh].bake = false;  // only the floor is baked
  const std::vector<Vec3> polygon(q, q + 4);
  const auto expected = texel_means(s, "floor", kW, [&](const Vec3& p, const Vec3& n) {
    return 10.0 * scene::polygon_projected_solid_angle(polygon, p, n);
  });
  LightmapBakeInput in = lightmap_input(s, kW, 0.01);
  in.min_samples = 64;
  const LightmapBakeResult r = bake_lightmaps(in);
  EXPECT_EQ(expect_matches(r, "floor", expected, kStorage, 1e-9, "emissive quad"), kW * kW);
}

// The bilinear interpolation of a 128 × 64 image blurs a sharp horizon over one pixel row (Δθ = π/64) symmetrically
// about it; for a plane the blurred band changes E by the curvature of its cosine weight across the band,
// O(Δθ²/12 · 2π) ≈ 1.3e-3 absolute at most, i.e. 5e-4 relative of π/2 or more: 1e-3 relative is allowed for it.
constexpr double kHorizonBlur = 1e-3;

// An environment image of radiance 1 above the horizon and 0 below: an upward plane gets π, a plane whose normal has
// elevation e gets π(1 + sin e)/2 (the sky's view factor).
TEST(LightmapLights, EnvironmentImageSkyGivesTheViewFactor) {
  const std::string sky = test::equirect_exr(128, 64, [](const Vec3& d) { return Rgb{d.y > 0 ? 1.0 : 0.0}; });
  {
    LightmapBakeInput in = lightmap_input(black_floor(), kW, 0.01);
    in.environment_image = sky;
    in.min_samples = 64;
    const LightmapBakeResult r = bake_lightmaps(in);
    EXPECT_EQ(expect_matches(r, "floor", std::vector<double>(kW * kW, kPi), kHorizonBlur, 0, "upward plane"), kW * kW);
  }
  for (double e : {0.0, kPi / 6, -kPi / 4}) {
    scene::Scene s;
    s.materials.push_back(lambert_material("black", 0.0));
    add_facing_quad(s, "tilted", {0, 0.5, 0}, {std::cos(e), std::sin(e), 0}, 0.5, 0);
    LightmapBakeInput in = lightmap_input(s, kW, 0.01);
    in.environment_image = sky;
    in.min_samples = 64;
    // A plane facing 45° down wastes most environment samples behind it and would take the full 4096 estimates
    // per texel (9 s): 1024 keep the test short; the tolerance follows the error estimate either way.
    in.max_samples = 1024;
    const LightmapBakeResult r = bake_lightmaps(in);
    const double want = kPi * (1 + std::sin(e)) / 2;
    EXPECT_EQ(expect_matches(r, "tilted", std::vector<double>(kW * kW, want), kHorizonBlur, 0,
                             "elevation " + std::to_string(e)),
              kW * kW);
  }
}

// Rotation: an image bright (1) towards +X and black towards −X, turned 90° about +Y, is bright towards −Z
// (env_input.h: what the input showed towards +X is seen towards −Z). A plane facing −Z then sees only sky (π), one
// facing +Z none (0, up to the blur of the boundary meridian at its horizon: kHorizonBlur of π absolute). A constant
// environment is unchanged by any rotation (π on an upward plane, exactly).
TEST(LightmapLights, EnvironmentRotationTurnsTheImageAboutY) {
  scene::Scene s;
  s.materials.push_back(lambert_material("black", 0.0));
  add_facing_quad(s, "north", {0, 0.5, -1}, {0, 0, -1}, 0.5, 0);
  add_facing_quad(s, "south", {0, 0.5, 1}, {0, 0, 1}, 0.5, 0);
  LightmapBakeInput in = lightmap_input(s, kW, 0.01);
  in.environment_image = test::equirect_exr(128, 64, [](const Vec3& d) { return Rgb{d.x > 0 ? 1.0 : 0.0}; });
  in.environment_decode.rotation_degrees = 90;
  in.min_samples = 64;
  // The +Z-facing quad receives ~0: its relative error never reaches any target, so it would run to max_samples;
  // 512 estimates bound its absolute error well inside the allowance below.
  in.max_samples = 512;
  const LightmapBakeResult r = bake_lightmaps(in);
  EXPECT_EQ(expect_matches(r, "north", std::vector<double>(kW * kW, kPi), kHorizonBlur, 0, "facing -Z"), kW * kW);
  EXPECT_EQ(expect_matches(r, "south", std::vector<double>(kW * kW, 0.0), 0, kHorizonBlur * kPi, "facing +Z"), kW * kW);

  scene::Scene c = black_floor();
  c.environment.constant = Rgb{1.0};
  c.environment.rotation_degrees = 90;
  const LightmapBakeResult rc = bake_lightmaps(lightmap_input(c, kW, 0.01));
  EXPECT_EQ(expect_matches(rc, "floor", std::vector<double>(kW * kW, kPi), kStorage, 0, "rotated constant"), kW * kW);
}

// Two lights at once (a point light and a delta sun): E is the sum. Next-event estimation picks one light per
// sample by power, so the estimate is noisy although both lights are delta lights.
TEST(LightmapLights, TwoLightsAdd) {
  scene::Scene s = black_floor();
  scene::Light point;
  point.type = scene::LightShape::point;
  point.position = {-0.4, 1.0, 0.3};
  point.color = Rgb{3.0};
  scene::Light sun;
  sun.type = scene::LightShape::directional;
  sun.direction = normalize(Vec3{-0.5, -1, 0.4});
  sun.color = Rgb{1.5};
  s.lights = {point, sun};
  const auto expected = texel_means(s, "floor", kW, [&](const Vec3& p, const Vec3& n) {
    const Vec3 d = point.position - p;
    const double r = length(d);
    return point.color.r * std::max(0.0, dot(n, d / r)) / (r * r) + sun.color.r * std::max(0.0, dot(n, -sun.direction));
  });
  LightmapBakeInput in = lightmap_input(s, kW, 0.01);
  in.min_samples = 64;
  const LightmapBakeResult r = bake_lightmaps(in);
  EXPECT_EQ(expect_matches(r, "floor", expected, kStorage, 1e-9, "point + sun"), kW * kW);
}

}  // namespace
}  // namespace kiln::lightmap
