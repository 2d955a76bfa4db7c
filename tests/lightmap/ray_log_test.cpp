// The ray log the lightmap benchmark replays through raw Embree (bakers/lightmap/ray_log.h): it receives exactly the
// bake's rays, each marked with its kind (transport closest-hit, shadow, leak probe), the transport's starting where
// the bake's receivers are, and a full log counts what it drops.
#include "bakers/lightmap/ray_log.h"

#include <gtest/gtest.h>

#include <cmath>

#include "bakers/lightmap/lightmap_bake.h"
#include "tests/support/test_scenes.h"

namespace kiln::lightmap {
namespace {

// A 2 m floor (y = 0, facing +Y) under a point light 1 m above it: every texel traces a shadow ray to the light and
// a cosine ray that escapes (nothing else the rays can reach), so the counts are known. A lone floor cannot leak and
// gets no leak probe (leak_scope.h): a strip beside it in its plane (not baked, out of every ray's way) makes the
// floor's points near it be probed.
LightmapBakeInput lit_floor() {
  scene::Scene s = test::floor_under_point_light(0.5, {0, 1, 0}, Rgb{1.0});
  test::add_quad(s, "strip", {1, 0, 1}, {1.1, 0, 1}, {1.1, 0, -1}, {1, 0, -1}, 0, 1);
  s.instances.back().bake = false;
  LightmapBakeInput in = test::lightmap_input(s, 8, 0.1);
  in.min_samples = in.max_samples = 4;
  in.preview = false;
  return in;
}

TEST(RayLog, ReceivesEveryRayOfTheBakeWithItsKind) {
  LightmapBakeInput in = lit_floor();
  RayLog log(1 << 16);
  in.ray_log = &log;
  const LightmapBakeResult r = bake_lightmaps(in);
  ASSERT_GT(log.size(), 0u);
  EXPECT_EQ(log.size(), log.offered()) << "the log was large enough for every ray";
  EXPECT_EQ(log.offered(), r.rays) << "every ray the bake counts, and no other";
  size_t shadow = 0, probes = 0, closest = 0;
  for (size_t i = 0; i < log.size(); ++i) {
    const scene::Ray& ray = log.ray(i);
    ASSERT_TRUE(is_finite(ray.origin) && is_finite(ray.direction)) << "ray " << i;
    ASSERT_GT(ray.tmax, 0.0);
    // Every path and every leak probe starts on the floor and goes up (the floor faces the light; nothing else
    // reflects; probes cover the hemisphere above the sample point's normal).
    EXPECT_NEAR(ray.origin.y, 0.0, 1e-4) << "ray " << i;
    EXPECT_GT(ray.direction.y, 0.0) << "ray " << i;
    if (log.kind(i) == RayKind::occlusion) {
      ++shadow;
      // A shadow ray towards the point light ends just short of it (scene/ray_offset.h: direction = target − origin).
      const Vec3 end = ray.origin + ray.direction;
      EXPECT_NEAR(end.y, 1.0, 1e-9) << "ray " << i;
      EXPECT_LT(ray.tmax, 1.0);
    } else if (log.kind(i) == RayKind::probe) {
      ++probes;
    } else {
      ++closest;
    }
  }
  EXPECT_EQ(shadow, r.occlusion_rays);
  EXPECT_EQ(probes, r.probe_rays);
  EXPECT_GT(probes, 0u) << "the sample points near the strip are probed for leaks";
  // One shadow ray and one cosine ray per path: as many of each.
  EXPECT_EQ(shadow, closest);
}

TEST(RayLog, AFullLogKeepsItsCapacityAndCountsTheRest) {
  LightmapBakeInput in = lit_floor();
  RayLog log(10);
  in.ray_log = &log;
  const LightmapBakeResult r = bake_lightmaps(in);
  EXPECT_EQ(log.size(), 10u);
  EXPECT_GT(log.offered(), 10u);
  EXPECT_LE(log.offered(), r.rays);
}

}  // namespace
}  // namespace kiln::lightmap
