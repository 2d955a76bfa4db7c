// Light tracing (bakers/lightmap/light_tracing.h): the indirect light it deposits against an exact series, against
// gathering every texel's light for each kind of light, an honest error estimate, bytes that do not depend on the
// thread count, and the planner's decision.
#include "bakers/lightmap/light_tracing.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include <tbb/global_control.h>

#include "bakers/bake/invalid_input.h"
#include "bakers/lightmap/lightmap_bake.h"
#include "bakers/math/constants.h"
#include "bakers/plan/lightmap_plan.h"
#include "tests/support/test_scenes.h"

namespace kiln::lightmap {
namespace {

using test::add_box;
using test::lambert_material;

// The tests' bake input under the lightmap error metric, where the planner traces light.
LightmapBakeInput traced_input(scene::Scene s, int resolution, double target) {
  LightmapBakeInput in = test::lightmap_input(std::move(s), resolution, target);
  in.error_metric = ErrorMetric::lightmap;
  return in;
}

double luminance(const image::FloatImage& img, int x, int y) {
  return 0.2126 * img.at(x, y, 0) + 0.7152 * img.at(x, y, 1) + 0.0722 * img.at(x, y, 2);
}

// A lightmap as baked: per valid texel its luminance and standard error (the lightmap metric's error times the
// lightmap's brightness, the mean luminance of its valid texels).
struct Texels {
  int width = 0;
  std::vector<int> valid;
  std::vector<double> Y, se;
  double brightness = 0;
};

Texels texels(const LightmapBakeResult& r, const std::string& map) {
  const image::FloatImage E = test::exr_output(r, map + "_irradiance.exr");
  const image::FloatImage err = test::exr_output(r, map + "_error.exr");
  const image::FloatImage valid = test::exr_output(r, map + "_validity.exr");
  Texels t;
  t.width = E.width;
  double sum = 0;
  int n = 0;
  for (int y = 0; y < E.height; ++y) {
    for (int x = 0; x < E.width; ++x) {
      t.valid.push_back(valid.at(x, y, 0) == 1.0f);
      t.Y.push_back(luminance(E, x, y));
      t.se.push_back(err.at(x, y, 0));
      if (t.valid.back()) sum += t.Y.back(), ++n;
    }
  }
  t.brightness = n ? sum / n : 0;
  for (double& s : t.se) s *= t.brightness;
  return t;
}

// 1. A closed room whose walls all emit L_e and reflect ρ: the radiance everywhere is L_e (1 + ρ + … + ρ^B) for B
// bounces, so every texel's irradiance is π L_e Σ_{k≤B} ρ^k, of which the rays from the walls deposit everything
// past k = 0. Per texel within kEstimatedSigmas of its estimated standard error (test_scenes.h) plus float storage;
// the estimated errors honest: the RMS of the texels' actual errors within a factor 2 of the RMS of their estimates
// (what docs/LIGHTMAP.md promises of the estimate; 440 texels, so the ratio's own noise is a few per cent).
TEST(LightTracing, GlowingRoomMatchesTheSeriesOfBounces) {
  const double rho = 0.5, Le = 1.0;
  const int bounces = 3;
  scene::Scene s;
  s.materials.push_back(lambert_material("glow", rho, Rgb{Le}));
  add_box(s, "room", {-1, 0, -1}, {1, 2, 1}, 0, /*inward=*/true);
  LightmapBakeInput in = traced_input(s, 24, 0.02);
  in.max_bounces = bounces;
  const LightmapBakeResult r = bake_lightmaps(in);
  ASSERT_TRUE(r.light_tracing.on);
  EXPECT_GT(r.light_tracing.texels_traced, 4 * r.light_tracing.texels_gathered) << "most texels are traced";
  EXPECT_GT(r.light_tracing.deposits, 0u);
  double series = 0;
  for (int k = 0; k <= bounces; ++k) series += std::pow(rho, k);
  const double exact = kPi * Le * series;
  const Texels t = texels(r, "room");
  double actual2 = 0, estimated2 = 0;
  int n = 0;
  for (size_t i = 0; i < t.Y.size(); ++i) {
    if (!t.valid[i]) continue;
    EXPECT_NEAR(t.Y[i], exact, test::kEstimatedSigmas * t.se[i] + 1e-6 * exact) << "texel " << i;
    actual2 += (t.Y[i] - exact) * (t.Y[i] - exact);
    estimated2 += t.se[i] * t.se[i];
    ++n;
  }
  ASSERT_GT(n, 300);
  const double ratio = std::sqrt(actual2 / estimated2);
  EXPECT_GT(ratio, 0.5);
  EXPECT_LT(ratio, 2.0);
}

// A closed room of white walls (ρ = 0.5) lit by one light of the given kind, near its ceiling.
scene::Scene room_lit_by(scene::LightShape shape) {
  scene::Scene s;
  s.materials.push_back(lambert_material("walls", 0.5));
  add_box(s, "room", {-1, 0, -1}, {1, 2, 1}, 0, /*inward=*/true);
  scene::Light l;
  l.type = shape;
  l.position = {0.2, 1.7, 0.1};
  l.direction = {0.1, -1, 0};
  l.color = Rgb{4.0, 3.0, 2.0};
  l.u_axis = {0.4, 0, 0};
  l.v_axis = {0, 0, 0.3};
  l.radius = 0.2;
  l.inner_cone = 0.3;
  l.outer_cone = 0.8;
  s.lights.push_back(l);
  return s;
}

// An emissive patch under the ceiling of the same room, facing down.
scene::Scene room_lit_by_a_patch() {
  scene::Scene s;
  s.materials.push_back(lambert_material("walls", 0.5));
  s.materials.push_back(lambert_material("patch", 0.5, Rgb{8.0, 6.0, 4.0}));
  add_box(s, "room", {-1, 0, -1}, {1, 2, 1}, 0, /*inward=*/true);
  test::add_quad(s, "patch", {-0.2, 1.9, -0.2}, {0.2, 1.9, -0.2}, {0.2, 1.9, 0.2}, {-0.2, 1.9, 0.2}, 1);
  return s;
}

// Traced and gathered agree within their noise: per texel within kEstimatedSigmas combined standard errors, and
// the mean over the room within 4 standard errors of the mean (texels' errors independent). (Its speed is
// lightmap_bench's and the Cornell benchmark's to show: on maps this small the rays' floor of a few per texel
// dominates.)
void expect_traced_equals_gathered(const scene::Scene& s, const std::string& what) {
  const LightmapBakeInput traced_in = traced_input(s, 16, 0.03);
  LightmapBakeInput gathered_in = traced_in;
  gathered_in.force_effects["light_tracing"] = false;
  const LightmapBakeResult traced = bake_lightmaps(traced_in), gathered = bake_lightmaps(gathered_in);
  ASSERT_TRUE(traced.light_tracing.on) << what;
  ASSERT_FALSE(gathered.light_tracing.on) << what;
  const Texels a = texels(traced, "room"), b = texels(gathered, "room");
  double diff = 0, var = 0;
  for (size_t i = 0; i < a.Y.size(); ++i) {
    if (!a.valid[i]) continue;
    const double sigma = std::hypot(a.se[i], b.se[i]);
    EXPECT_NEAR(a.Y[i], b.Y[i], test::kEstimatedSigmas * sigma + 1e-6 * b.Y[i]) << what << " texel " << i;
    diff += a.Y[i] - b.Y[i];
    var += sigma * sigma;
  }
  EXPECT_LT(std::fabs(diff), 4 * std::sqrt(var)) << what << ": the means differ by more than the noise";
}

TEST(LightTracing, PointLightAgreesWithGathering) {
  expect_traced_equals_gathered(room_lit_by(scene::LightShape::point), "point");
}
TEST(LightTracing, SpotLightAgreesWithGathering) {
  expect_traced_equals_gathered(room_lit_by(scene::LightShape::spot), "spot");
}
TEST(LightTracing, RectLightAgreesWithGathering) {
  expect_traced_equals_gathered(room_lit_by(scene::LightShape::rect), "rect");
}
TEST(LightTracing, DiskLightAgreesWithGathering) {
  expect_traced_equals_gathered(room_lit_by(scene::LightShape::disk), "disk");
}
TEST(LightTracing, EmissiveTrianglesAgreeWithGathering) {
  expect_traced_equals_gathered(room_lit_by_a_patch(), "emissive patch");
}

// A delta light the plan does not sample (forced off) reaches no gathered path, so it sends no rays either: the room
// stays black, exactly.
TEST(LightTracing, ALightForcedOffSendsNoRays) {
  LightmapBakeInput in = traced_input(room_lit_by(scene::LightShape::point), 8, 0.05);
  in.force_effects["point_lights"] = false;
  const LightmapBakeResult r = bake_lightmaps(in);
  EXPECT_EQ(r.light_tracing.light_rays, 0u);
  const Texels t = texels(r, "room");
  for (size_t i = 0; i < t.Y.size(); ++i) EXPECT_EQ(t.Y[i], 0.0) << "texel " << i;
}

// Deposits are summed in fixed point and every block of rays has its own stream: the same bytes on 1 and 2 threads.
TEST(LightTracing, BytesDoNotDependOnTheThreadCount) {
  const LightmapBakeInput in = traced_input(test::cornell_box(), 8, 0.05);
  auto bake_with = [&](int threads) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    return bake_lightmaps(in);
  };
  const LightmapBakeResult one = bake_with(1), two = bake_with(2);
  ASSERT_TRUE(one.light_tracing.on);
  EXPECT_EQ(one.light_tracing.light_rays, two.light_tracing.light_rays);
  for (const char* name : {"floor_irradiance.exr", "floor_error.exr", "tall_block_irradiance.exr"}) {
    EXPECT_EQ(test::find_output(one, name).bytes, test::find_output(two, name).bytes) << name;
  }
}

// Texels whose points leak handling moved (the floor under the blocks) and texels with shading normals gather all
// their light.
TEST(LightTracing, MovedAndSmoothTexelsAreNotTraced) {
  scene::Scene s = test::cornell_box();
  const LightmapBakeResult r = bake_lightmaps(traced_input(s, 16, 0.1));
  EXPECT_GT(r.light_tracing.texels_gathered, 0u) << "the floor under the blocks";
  scene::Scene sphere;
  sphere.materials.push_back(lambert_material("glow", 0.5, Rgb{1.0}));
  test::add_sphere(sphere, "sphere", {0, 0, 0}, 1.0, 8, 0, /*inward=*/true, /*smooth=*/true);
  const LightmapBakeResult smooth = bake_lightmaps(traced_input(sphere, 8, 0.1));
  ASSERT_TRUE(smooth.light_tracing.on);
  EXPECT_EQ(smooth.light_tracing.texels_traced, 0u) << "interpolated normals: every texel gathers";
}

// The planner traces light only where it can serve the bake, and says why not.
plan::LightmapPlan plan_for(const scene::Scene& s, bool directional, bool per_texel,
                            std::map<std::string, bool> force = {}) {
  plan::LightmapPlanOptions o;
  o.target_error = 0.02;
  o.directional = directional;
  o.per_texel_error = per_texel;
  o.force_effects = std::move(force);
  return plan::plan_lightmap(s, o);
}

std::string reason(const plan::LightmapPlan& p) {
  for (const plan::Decision& d : p.decisions) {
    if (d.effect == "light_tracing") return d.reason;
  }
  return "no decision";
}

TEST(LightTracing, ThePlannerSaysWhenAndWhyNot) {
  const scene::Scene room = room_lit_by(scene::LightShape::point);
  EXPECT_TRUE(plan_for(room, false, false).light_tracing) << reason(plan_for(room, false, false));
  const plan::LightmapPlan directional = plan_for(room, true, false);
  EXPECT_FALSE(directional.light_tracing);
  EXPECT_NE(reason(directional).find("directional (SH) output"), std::string::npos) << reason(directional);
  const plan::LightmapPlan per_texel = plan_for(room, false, true);
  EXPECT_FALSE(per_texel.light_tracing);
  EXPECT_NE(reason(per_texel).find("texel error metric"), std::string::npos) << reason(per_texel);
  scene::Scene sky = room;
  sky.environment.constant = Rgb{0.5};
  const plan::LightmapPlan with_sky = plan_for(sky, false, false);
  EXPECT_FALSE(with_sky.light_tracing);
  EXPECT_NE(reason(with_sky).find("infinitely far"), std::string::npos) << reason(with_sky);
  EXPECT_FALSE(plan_for(room, false, false, {{"light_tracing", false}}).light_tracing);
  try {
    plan_for(sky, false, false, {{"light_tracing", true}});
    ADD_FAILURE() << "forcing light tracing on under a sky must be refused";
  } catch (const bake::InvalidInput& e) {
    EXPECT_EQ(e.field(), "force_effects");
    EXPECT_NE(std::string(e.what()).find("infinitely far"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace kiln::lightmap
