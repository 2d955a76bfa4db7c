// The lightmap report times every stage of a bake (its `stages` list), and a bake that the time limit ends before
// its first sample reports an unknown error estimate (−1 in the result, null in report.json), never 0.
#include <gtest/gtest.h>

#include <chrono>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <thread>

#include "bakers/lightmap/lightmap_bake.h"
#include "tests/support/test_scenes.h"

namespace kiln::lightmap {
namespace {

scene::Scene floor_under_sky() {
  scene::Scene s;
  s.materials.push_back(test::lambert_material("grey", 0.5));
  test::add_floor(s, 2.0, 0, 2);
  s.environment.constant = Rgb{1.0};
  return s;
}

nlohmann::json report_of(const LightmapBakeResult& r) {
  return nlohmann::json::parse(test::find_output(r, "report.json").bytes);
}

// Each stage of `expected` appears once in the report, with its seconds and its fraction of the bake's; the stages
// do not overlap, and the report is written after them: their sum stays within the bake's time, and covers most of it.
void expect_stages_timed(const LightmapBakeResult& r, std::initializer_list<const char*> expected) {
  const nlohmann::json report = report_of(r);
  ASSERT_TRUE(report.contains("stages"));
  std::set<std::string> names;
  double sum = 0;
  for (const auto& st : report["stages"]) {
    EXPECT_TRUE(names.insert(st["stage"].get<std::string>()).second) << "each stage once: " << st["stage"];
    const double s = st["seconds"].get<double>();
    EXPECT_GE(s, 0.0);
    EXPECT_NEAR(st["fraction"].get<double>(), s / r.seconds, 1e-12);
    sum += s;
  }
  for (const char* stage : expected) EXPECT_EQ(names.count(stage), 1u) << stage;
  EXPECT_LE(sum, r.seconds);
  EXPECT_GT(sum, 0.5 * r.seconds);
}

TEST(LightmapStages, EveryStageIsTimedInTheReport) {
  LightmapBakeInput in = test::lightmap_input(floor_under_sky(), 16, 0.05);
  const LightmapBakeResult r = bake_lightmaps(in);
  expect_stages_timed(r, {"scene", "plan", "tracer", "lights", "leak_scope", "rasterization", "leak_probes",
                          "light_tracing_setup", "passes", "outputs"});
  EXPECT_GE(r.error_estimate, 0.0);
  EXPECT_EQ(report_of(r)["error_estimate"].get<double>(), r.error_estimate);
}

// A bake in tiles (tile_size 16 on a 32² floor: 4 tiles) times the same stages, summed over its tiles, and the binning
// of the triangles into tiles; it has no light tracing.
TEST(LightmapStages, EveryStageOfATiledBakeIsTimedInTheReport) {
  LightmapBakeInput in = test::lightmap_input(floor_under_sky(), 32, 0.05);
  in.tile_size = 16;
  const LightmapBakeResult r = bake_lightmaps(in);
  ASSERT_TRUE(report_of(r)["memory"]["tiled"].get<bool>());
  expect_stages_timed(r, {"scene", "plan", "tracer", "lights", "tile_binning", "leak_scope", "rasterization",
                          "leak_probes", "passes", "outputs"});
}

// The set-up finishes within the limit, then the progress callback (at the end of the set-up, stage "texels") holds
// the bake until the limit has passed: the passes end before the first sample. 3 s of limit: the set-up of a 16²
// floor takes milliseconds even on a loaded machine.
TEST(LightmapStages, ABakeEndedBeforeItsFirstSampleHasAnUnknownErrorEstimate) {
  LightmapBakeInput in = test::lightmap_input(floor_under_sky(), 16, 0.05);
  in.time_limit_seconds = 3;
  const auto t0 = std::chrono::steady_clock::now();
  bool held = false;
  bake::BakeControl control;
  control.progress = [&](const bake::BakeProgress& p) {
    if (p.stage != "texels" || held) return;
    held = true;
    std::this_thread::sleep_until(t0 + std::chrono::milliseconds(3200));
  };
  const LightmapBakeResult r = bake_lightmaps(in, control);
  ASSERT_TRUE(held);
  EXPECT_EQ(r.samples, 0u);
  EXPECT_LT(r.error_estimate, 0.0);  // unknown, not 0
  const nlohmann::json report = report_of(r);
  EXPECT_TRUE(report["error_estimate"].is_null());
  EXPECT_NE(report["error_estimate_unknown"].get<std::string>().find("no texel was sampled"), std::string::npos);
}

}  // namespace
}  // namespace kiln::lightmap
