// Cancel and the time limit reach every stage of the lightmap bake, the set-up included: each stage stops at its
// next poll of a bake::StopCheck, and a whole bake whose time limit runs out during the set-up (or whose cancel flag
// is set then) ends within a bounded time instead of finishing the set-up first.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "bakers/bake/cancelled.h"
#include "bakers/bake/stop.h"
#include "bakers/lightmap/dilate.h"
#include "bakers/lightmap/leaks.h"
#include "bakers/lightmap/lightmap_bake.h"
#include "bakers/lightmap/texels.h"
#include "bakers/lightmap/tracer_query.h"
#include "bakers/scene/scene_check.h"
#include "bakers/scene/tracer.h"
#include "tests/support/test_scenes.h"

namespace kiln::lightmap {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Bakes `in`, cancelling it after `delay`; the seconds from the cancel to the bake's end (a BakeCancelled).
double seconds_to_cancel(const LightmapBakeInput& in, std::chrono::milliseconds delay) {
  std::atomic<bool> cancel{false};
  bake::BakeControl control;
  control.cancel = &cancel;
  Clock::time_point cancelled_at;
  std::thread canceller([&] {
    std::this_thread::sleep_for(delay);
    cancelled_at = Clock::now();
    cancel = true;
  });
  EXPECT_THROW(bake_lightmaps(in, control), bake::BakeCancelled);
  const Clock::time_point ended = Clock::now();
  canceller.join();
  return std::chrono::duration<double>(ended - cancelled_at).count();
}

scene::Scene floor_scene(int n = 4) {
  scene::Scene s;
  s.materials.push_back(test::lambert_material("grey", 0.5));
  test::add_floor(s, 2.0, 0, n);
  s.environment.constant = Rgb{1.0};
  return s;
}

const std::atomic<bool> kCancelled{true};
bake::StopCheck cancelled() { return bake::StopCheck(&kCancelled, Clock::time_point::max()); }
bake::StopCheck past_deadline() { return bake::StopCheck(nullptr, Clock::now() - std::chrono::seconds(1)); }

TEST(StopCheck, CancelWinsOverTheDeadlineAndNothingSetNeverStops) {
  EXPECT_FALSE(bake::StopCheck{}.requested());
  EXPECT_NO_THROW(bake::StopCheck{}.check());
  EXPECT_THROW(bake::StopCheck(&kCancelled, Clock::now() - std::chrono::seconds(1)).check(), bake::BakeCancelled);
  EXPECT_THROW(past_deadline().check(), bake::OutOfTime);
}

TEST(BakeStop, RasterizationStops) {
  const scene::Scene s = floor_scene();
  RasterOptions o;
  o.width = o.height = 64;
  EXPECT_THROW(rasterize_lightmap(s, "floor", o, cancelled()), bake::BakeCancelled);
  EXPECT_THROW(rasterize_lightmap(s, "floor", o, past_deadline()), bake::OutOfTime);
  EXPECT_GT(rasterize_lightmap(s, "floor", o).valid_count(), 0u);
}

TEST(BakeStop, TracerBuildStops) {
  const scene::CheckedScene checked = scene::check_scene(floor_scene());
  scene::TracerOptions o;
  const bake::StopCheck c = cancelled(), d = past_deadline();
  o.stop = &c;
  EXPECT_THROW(scene::Tracer(checked.scene, o), bake::BakeCancelled);
  o.stop = &d;
  EXPECT_THROW(scene::Tracer(checked.scene, o), bake::OutOfTime);
}

TEST(BakeStop, LeakProbesStopAndLeaveTheTexelsAsTheyWere) {
  const scene::CheckedScene checked = scene::check_scene(floor_scene());
  const scene::Tracer tracer(checked.scene);
  const TracerRayQuery query(tracer, checked.scene);
  RasterOptions o;
  o.width = o.height = 32;
  LightmapTexels texels = rasterize_lightmap(checked.scene, "floor", o);
  const size_t samples = texels.samples.size();
  EXPECT_THROW(fix_leaks(texels, query, LeakOptions{}, cancelled()), bake::BakeCancelled);
  EXPECT_THROW(fix_leaks(texels, query, LeakOptions{}, past_deadline()), bake::OutOfTime);
  EXPECT_EQ(texels.samples.size(), samples);
}

TEST(BakeStop, DilationStops) {
  image::FloatImage img;
  img.width = img.height = 16;
  img.channels = 1;
  img.pixels.assign(256, 0.0f);
  std::vector<uint8_t> valid(256, 0);
  valid[0] = 1;
  EXPECT_THROW(dilate(img, valid, 4, cancelled()), bake::BakeCancelled);
  EXPECT_GT(dilate(img, valid, 4), 0u);
}

// A room (a box facing inwards) in a lightmap of 1024² texels: its walls see each other, so it is neither convex
// nor a height field and every sample point is probed for leaks (leak_scope.h; a lone floor would get no probe):
// ~2.5 M points × 32 rays is ~10⁸ rays of set-up (tens of seconds on two cores). With a time limit of 1 s the bake
// must end soon after that second: each stage polls every few milliseconds of work, so 1 s of slack covers the poll
// and the unwinding with a wide margin on a loaded machine.
LightmapBakeInput big_room() {
  scene::Scene s;
  s.materials.push_back(test::lambert_material("grey", 0.5));
  test::add_box(s, "room", {-1, 0, -1}, {1, 2, 1}, 0, true);
  s.environment.constant = Rgb{1.0};
  return test::lightmap_input(s, 1024, 0.01);
}

TEST(BakeStop, ATimeLimitEndsABigSetUpNamingTheField) {
  LightmapBakeInput in = big_room();
  in.time_limit_seconds = 1;
  const Clock::time_point t0 = Clock::now();
  try {
    bake_lightmaps(in);
    FAIL() << "the set-up of a 1024² lightmap should not fit in 1 s";
  } catch (const bake::InvalidInput& e) {
    EXPECT_EQ(e.field(), "time_limit_seconds");
    EXPECT_NE(e.problem().find("set-up"), std::string::npos) << e.problem();
  }
  const double seconds = seconds_since(t0);
  EXPECT_LT(seconds, 2.0) << "the time limit is 1 s";
  std::printf("1024² room, time limit 1 s: ended after %.2f s\n", seconds);
}

TEST(BakeStop, ACancelDuringTheSetUpEndsTheBakeWithinASecond) {
  const LightmapBakeInput in = big_room();
  const double after = seconds_to_cancel(in, std::chrono::milliseconds(500));
  EXPECT_LT(after, 1.0);
  std::printf("1024² room, cancelled 0.5 s into the set-up: ended %.3f s after the cancel\n", after);
}

// A tiled bake (LightmapBakeInput::tile_size) budgets its time limit among the tiles (tile_time_budget.h): it ends
// within about the limit, every tile it did not sample still has its texels' validity (only sampling is skipped), and
// the report says how many tiles were left unsampled and what the budget forecast by. 1.5 s of slack: the pass under
// way when a tile's share runs out runs to its end, and on a slow, shared machine a page's outputs (~0.3 s for two
// 256² pages) may take more than forecast.
TEST(BakeStop, ATiledBakeKeepsItsTimeLimit) {
  LightmapBakeInput in = test::lightmap_input(floor_scene(), 256, 0.0005);
  in.tile_size = 32;
  in.max_samples = 1 << 20;
  in.time_limit_seconds = 1.5;
  const Clock::time_point t0 = Clock::now();
  const LightmapBakeResult r = bake_lightmaps(in);
  const double seconds = seconds_since(t0);
  EXPECT_LT(seconds, in.time_limit_seconds + 1.5);
  EXPECT_GT(r.samples, 0u);
  EXPECT_EQ(r.memory.tiles, 64u);
  const image::FloatImage valid = test::exr_output(r, "floor_validity.exr");
  for (float v : valid.pixels) ASSERT_EQ(v, 1.0f) << "the floor covers every texel, sampled or not";
  const LightmapBakeResult::TimeBudget& b = r.time_budget;
  EXPECT_TRUE(b.on);
  EXPECT_GT(b.sampled_rate, 0) << "measured on the tiles sampled";
  EXPECT_GT(b.output_rate, 0);
  if (r.memory.tiles_unsampled > 0) {
    EXPECT_GE(b.sampling_ended_seconds, 0) << "tiles were left unsampled: the report says when";
    EXPECT_GT(b.forecast_seconds, 0);
    EXPECT_GT(b.after_seconds, 0);
  }
  std::printf("256² floor in 32² tiles, time limit 1.5 s: ended after %.2f s, %llu of 64 tiles unsampled\n", seconds,
              static_cast<unsigned long long>(r.memory.tiles_unsampled));
}

TEST(BakeStop, ACancelStopsATiledBake) {
  LightmapBakeInput in = test::lightmap_input(floor_scene(), 256, 0.0005);
  in.tile_size = 32;
  in.max_samples = 1 << 20;
  const double after = seconds_to_cancel(in, std::chrono::milliseconds(700));
  EXPECT_LT(after, 1.0);
  std::printf("256² floor in 32² tiles, cancelled after 0.7 s: ended %.3f s after the cancel\n", after);
}

}  // namespace
}  // namespace kiln::lightmap
