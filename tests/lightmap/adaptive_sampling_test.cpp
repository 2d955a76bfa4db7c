// The adaptive sampling's stopping rules, seen from outside the bake: the rule-of-three floor on texels whose
// estimates barely vary, batches that grow so a bake takes few passes, and a time limit that holds inside a pass.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <thread>

#include <tbb/global_control.h>

#include "bakers/lightmap/lightmap_bake.h"
#include "bakers/lightmap/path_sampler.h"
#include "bakers/math/constants.h"
#include "tests/support/test_scenes.h"

namespace kiln::lightmap {
namespace {

using test::add_floor;
using test::lambert_material;
using test::lightmap_input;

// A 2 m floor in the open under a uniform sky of radiance 1: every estimate is π up to rounding (see
// lightmap_bake_test), so a texel's own variance would let it stop at min_samples.
scene::Scene sky_floor() {
  scene::Scene s;
  s.materials.push_back(lambert_material("grey", 0.5));
  add_floor(s, 2.0, 0, 2);
  s.environment.constant = Rgb{1.0};
  return s;
}

// The same floor lit only from below (a point light under it, which its one-sided lightmap never sees): every
// estimate is exactly 0.
scene::Scene black_floor() {
  scene::Scene s;
  s.materials.push_back(lambert_material("grey", 0.5));
  add_floor(s, 2.0, 0, 2);
  scene::Light below;
  below.type = scene::LightShape::point;
  below.position = {0, -1, 0};
  below.color = Rgb{10.0};
  s.lights = {below};
  return s;
}

LightmapBakeResult budget_bake(const scene::Scene& s, uint64_t samples) {
  LightmapBakeInput in = lightmap_input(s, 8, 1e-4);
  in.min_samples = in.max_samples = samples;
  return bake_lightmaps(in);
}

// Rule of three: at target 0.02 no texel stops before its paths number 3/0.02 = 150, however little they vary.
// A texel of this floor has 2 × 2 sample points (more where the diagonal splits it between triangles), so an estimate
// is at least 4 paths: at most 38 estimates, rounded up to whole rounds of the replicas (batches are), 40. So the
// adaptive bake traces at least 150 paths per texel and at most what a budget bake of 40 estimates traces.
TEST(AdaptiveSampling, TexelsThatDoNotVaryStillTakeThreeOverTargetPaths) {
  const double target = 0.02;
  const uint64_t most =
      (static_cast<uint64_t>(std::ceil(std::ceil(3 / target) / 4)) + kReplicas - 1) / kReplicas * kReplicas;
  ASSERT_EQ(most, 40u);  // with kReplicas = 8; the arithmetic above is the rule, this its instance
  for (const scene::Scene& s : {sky_floor(), black_floor()}) {
    LightmapBakeInput in = lightmap_input(s, 8, target);
    in.min_samples = 4;
    const LightmapBakeResult adaptive = bake_lightmaps(in);
    const LightmapBakeResult at_min = budget_bake(s, 4), at_most = budget_bake(s, most);
    EXPECT_GT(adaptive.samples, at_min.samples) << "stopped at min_samples on a texel with no variance";
    EXPECT_GE(adaptive.samples, 150u * 8 * 8);
    EXPECT_LE(adaptive.samples, at_most.samples);
  }
}

// Batches grow with what a texel has (by half, at least one), so 1024 estimates per texel take ~18 passes, not
// 1024: the count of curve points (one per pass) is the number of passes. The bound 2·log_1.5(1024) = 34 leaves
// room for the first passes of one estimate.
TEST(AdaptiveSampling, ABudgetOfNEstimatesTakesLogarithmicallyManyPasses) {
  const LightmapBakeResult r = budget_bake(sky_floor(), 1024);
  EXPECT_LE(r.curve.size(), 34u);
  EXPECT_GE(r.curve.size(), 10u) << "batches jumped: the error-versus-time curve would have too few points";
  for (size_t i = 1; i < r.curve.size(); ++i) {
    EXPECT_GT(r.curve[i].samples, r.curve[i - 1].samples) << "pass " << i << " added nothing";
    EXPECT_GE(r.curve[i].seconds, r.curve[i - 1].seconds);
  }
}

// A time limit already past when sampling starts: no estimate is taken (the limit is checked before every texel,
// inside the pass), the bake still ends normally and every output is there, with error 1 (no estimate) at every
// valid texel. (A limit that runs out during the set-up fails the bake instead, bake_stop_test.) The set-up of an 8²
// Cornell box takes milliseconds; its last progress report (stage "texels", just before sampling) waits until the
// 2 s limit has passed.
TEST(AdaptiveSampling, ATimeLimitHoldsInsideAPass) {
  LightmapBakeInput in = lightmap_input(test::cornell_box(), 8, 1e-3);
  in.time_limit_seconds = 2;
  const auto t0 = std::chrono::steady_clock::now();
  bake::BakeControl control;
  control.progress = [&](const bake::BakeProgress& p) {
    if (p.stage == "texels") std::this_thread::sleep_until(t0 + std::chrono::milliseconds(2100));
  };
  const LightmapBakeResult r = bake_lightmaps(in, control);
  EXPECT_EQ(r.samples, 0u);
  ASSERT_EQ(r.curve.size(), 1u);
  const image::FloatImage err = test::exr_output(r, "floor_error.exr");
  const image::FloatImage valid = test::exr_output(r, "floor_validity.exr");
  int valid_texels = 0;
  for (int y = 0; y < err.height; ++y) {
    for (int x = 0; x < err.width; ++x) {
      if (valid.at(x, y, 0) != 1.0f) continue;
      ++valid_texels;
      EXPECT_EQ(err.at(x, y, 0), 1.0f) << x << "," << y;
    }
  }
  EXPECT_GT(valid_texels, 0);
}

// The same input and seed give the same bytes on 1 thread and on 2, through the late passes where few texels
// remain and their batches are split over several work items (an adaptive bake of the Cornell box at a target most
// texels reach early and a few reach late).
TEST(AdaptiveSampling, TheBytesDoNotDependOnTheThreads) {
  LightmapBakeInput in = lightmap_input(test::cornell_box(), 8, 0.03);
  in.min_samples = 8;
  auto bake_with = [&](int threads) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    return bake_lightmaps(in);
  };
  const LightmapBakeResult one = bake_with(1), two = bake_with(2);
  ASSERT_GT(one.curve.size(), 3u);
  EXPECT_EQ(one.samples, two.samples);
  for (const char* name : {"floor_irradiance.exr", "floor_error.exr", "tall_block_irradiance.exr"}) {
    EXPECT_EQ(test::find_output(one, name).bytes, test::find_output(two, name).bytes) << name;
  }
}

}  // namespace
}  // namespace kiln::lightmap
