// The lightmap bake's output sink (bake::BakeControl::output_sink): every output reaches it exactly once, in the
// order and with the bytes the bake returns without one, and the bake keeps none of them.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "bakers/lightmap/lightmap_bake.h"
#include "tests/support/test_scenes.h"

namespace kiln::lightmap {
namespace {

// Two lightmaps (a floor and a box) with every optional output, so that each kind passes through the sink.
LightmapBakeInput two_lightmaps() {
  scene::Scene s;
  s.materials.push_back(test::lambert_material("grey", 0.5));
  test::add_floor(s, 2.0, 0);
  test::add_box(s, "box", {-0.2, 0.0, -0.2}, {0.2, 0.4, 0.2}, 0);
  s.environment.constant = Rgb{1.0};
  LightmapBakeInput in = test::lightmap_input(s, 16, 0.05);
  in.max_samples = 64;
  in.preview = true;
  in.ao = true;
  in.radiance = true;
  in.denoise = true;
  return in;
}

TEST(LightmapStream, TheSinkReceivesEveryOutputOnceInOrder) {
  const LightmapBakeInput in = two_lightmaps();
  const LightmapBakeResult kept = bake_lightmaps(in);
  std::vector<bake::BakeOutput> streamed;
  bake::BakeControl control;
  control.output_sink = [&](bake::BakeOutput&& o) { streamed.push_back(std::move(o)); };
  const LightmapBakeResult r = bake_lightmaps(in, control);
  EXPECT_TRUE(r.outputs.empty()) << "a streaming bake keeps none of its outputs";
  ASSERT_EQ(streamed.size(), kept.outputs.size());
  for (size_t i = 0; i < streamed.size(); ++i) {
    EXPECT_EQ(streamed[i].name, kept.outputs[i].name) << i;
    EXPECT_EQ(streamed[i].media_type, kept.outputs[i].media_type) << streamed[i].name;
    EXPECT_EQ(streamed[i].color_space, kept.outputs[i].color_space) << streamed[i].name;
    // report.json holds the times, which differ from bake to bake; every image is the same bytes.
    if (streamed[i].name != "report.json") {
      EXPECT_EQ(streamed[i].bytes, kept.outputs[i].bytes) << streamed[i].name;
    }
  }
  EXPECT_EQ(streamed.back().name, "report.json");
  EXPECT_EQ(streamed.front().name, "floor_irradiance.exr");
}

TEST(LightmapStream, WhatTheSinkThrowsEndsTheBake) {
  bake::BakeControl control;
  int calls = 0;
  control.output_sink = [&](bake::BakeOutput&&) {
    if (++calls == 2) throw std::runtime_error("disk full");
  };
  EXPECT_THROW(bake_lightmaps(two_lightmaps(), control), std::runtime_error);
  EXPECT_EQ(calls, 2) << "no output is handed over after the sink failed";
}

}  // namespace
}  // namespace kiln::lightmap
