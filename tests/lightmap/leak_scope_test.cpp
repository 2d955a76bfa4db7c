// Leak probes only where they can matter (leak_scope.h): the mesh properties that rule out a mesh hiding its own
// points (convex, height field), a lone terrain that gets no probe ray at all, and a wall through a floor whose
// leaks are fixed exactly as with every point probed, with probes only near the wall.
#include "bakers/lightmap/leak_scope.h"

#include <gtest/gtest.h>

#include <cmath>

#include "bakers/lightmap/leaks.h"
#include "bakers/lightmap/lightmap_bake.h"
#include "bakers/lightmap/texels.h"
#include "bakers/lightmap/tracer_query.h"
#include "bakers/scene/scene_check.h"
#include "bakers/scene/tracer.h"
#include "tests/bench/level_scene.h"
#include "tests/support/test_scenes.h"

namespace kiln::lightmap {
namespace {

scene::Mesh only_mesh(const scene::Scene& s) { return s.meshes.at(0); }

scene::Mesh box_mesh(bool inward) {
  scene::Scene s;
  test::add_box(s, "box", {-1, 0, -1}, {1, 2, 1}, 0, inward);
  return only_mesh(s);
}

// Rolling hills: quads of 6 m against hills whose finest wave is 31 m long, so no valley is sharper than 90°.
bench::LevelOptions small_terrain(int quads) {
  bench::LevelOptions o;
  o.terrain_quads = quads;
  o.size = 6.25 * quads;
  o.hill_height = 5;
  o.meshes = 0;
  o.instances = 0;
  return o;
}

// Two stacked floors in one mesh (a ramp's two levels): every normal is up, but the projections overlap.
scene::Mesh two_levels() {
  scene::Scene s;
  test::add_quad(s, "lower", {-1, 0, 1}, {1, 0, 1}, {1, 0, -1}, {-1, 0, -1}, 0, 2);
  test::add_quad(s, "upper", {-0.5, 1, 1.5}, {1.5, 1, 1.5}, {1.5, 1, -0.5}, {-0.5, 1, -0.5}, 0, 2);
  scene::Mesh m = s.meshes[0];
  const uint32_t base = static_cast<uint32_t>(m.positions.size());
  for (const Vec3& p : s.meshes[1].positions) m.positions.push_back(p);
  for (const Point2& uv : s.meshes[1].lightmap_uv) m.lightmap_uv.push_back(uv);
  for (uint32_t i : s.meshes[1].indices) m.indices.push_back(base + i);
  return m;
}

TEST(LeakScope, ConvexMeshesAndHeightFieldsCannotHideTheirOwnPoints) {
  scene::Scene plane;
  test::add_floor(plane, 2.0, 0, 8);
  EXPECT_TRUE(is_convex_mesh(only_mesh(plane)));  // a plane: everything on its own plane
  EXPECT_TRUE(is_convex_mesh(box_mesh(false)));
  EXPECT_FALSE(is_convex_mesh(box_mesh(true)));  // a room: each wall sees the others in front of it
  EXPECT_FALSE(is_height_field(box_mesh(true)));
  EXPECT_FALSE(is_height_field(box_mesh(false)));  // vertical sides
  const scene::Mesh terrain = bench::terrain_mesh(small_terrain(64));
  EXPECT_FALSE(is_convex_mesh(terrain));  // hills and valleys
  EXPECT_TRUE(is_height_field(terrain));
  EXPECT_FALSE(is_height_field(two_levels()));
  // The same 5 m hills squeezed into 100 m on 3 m quads have valleys sharper than 90° across some quads' diagonals
  // (their finest wave is 7.7 m long): a point on such a crease, lifted off one side, is behind the other, and a
  // full probe does find such points "inside" (176 of 65,536 at 64²).
  bench::LevelOptions coarse = small_terrain(32);
  coarse.size = 100;
  EXPECT_FALSE(is_height_field(bench::terrain_mesh(coarse)));
  EXPECT_FALSE(is_convex_mesh(two_levels()));
  // Turned upside down (winding reversed), the terrain faces −y: still a height field, along −y.
  scene::Mesh flipped = terrain;
  for (size_t t = 0; t < flipped.indices.size(); t += 3) std::swap(flipped.indices[t + 1], flipped.indices[t + 2]);
  EXPECT_TRUE(is_height_field(flipped));
}

// A lone open terrain (a height field, nothing else in the scene): no sample can leak, no probe ray is traced, in
// fix_leaks and in a whole bake.
TEST(LeakScope, ALoneTerrainGetsNoProbeRays) {
  scene::Scene s;
  s.materials.push_back(test::lambert_material("ground", 0.5));
  s.meshes.push_back(bench::terrain_mesh(small_terrain(32)));
  s.meshes[0].material.assign(s.meshes[0].indices.size() / 3, 0);
  s.instances.push_back({});
  s.environment.constant = Rgb{1.0};
  const scene::CheckedScene checked = scene::check_scene(s);
  const LeakScope scope(checked.scene);
  EXPECT_EQ(scope.summary().height_field_meshes, 1u);
  LightmapTexels texels = rasterize_lightmap(checked.scene, "terrain", {64, 64, 2});
  ASSERT_GT(texels.samples.size(), 10000u);
  const std::vector<uint8_t> mask = scope.probe_mask(texels.samples);
  const scene::Tracer tracer(checked.scene);
  const LeakReport r = fix_leaks(texels, TracerRayQuery(tracer, checked.scene), {}, {}, &mask);
  EXPECT_EQ(r.rays, 0u);
  EXPECT_EQ(r.pruned, r.samples);
  // And without the mask every point would have been probed (and found clear): what pruning saves.
  LightmapTexels all = rasterize_lightmap(checked.scene, "terrain", {64, 64, 2});
  const LeakReport full = fix_leaks(all, TracerRayQuery(tracer, checked.scene), {});
  EXPECT_EQ(full.rays, 32u * full.samples);
  EXPECT_EQ(full.moved + full.invalidated, 0u);

  LightmapBakeInput in = test::lightmap_input(s, 32, 0.2);
  in.min_samples = 4;
  in.max_samples = 8;
  const LightmapBakeResult result = bake_lightmaps(in);
  EXPECT_EQ(result.probe_rays, 0u);
  EXPECT_GT(result.samples, 0u);
}

// A 0.2 m thick wall standing through a 2 m floor (the wall a separate instance, 1 m tall and sunk 0.5 m into the
// ground): the floor's samples under the wall are moved out or dropped exactly as when every sample is probed, and
// only samples near the wall are probed.
TEST(LeakScope, AWallThroughAFloorStillGetsItsLeaksFixed) {
  scene::Scene s;
  s.materials.push_back(test::lambert_material("white", 0.5));
  test::add_floor(s, 2.0, 0, 8);
  test::add_box(s, "wall", {-0.1, -0.5, -1.5}, {0.1, 0.5, 1.5}, 0);
  const scene::CheckedScene checked = scene::check_scene(s);
  const scene::Tracer tracer(checked.scene);
  const TracerRayQuery query(tracer, checked.scene);
  const LeakScope scope(checked.scene);
  EXPECT_EQ(scope.summary().convex_meshes, 2u);  // the floor and the box: only the other can hide a point

  LightmapTexels pruned = rasterize_lightmap(checked.scene, "floor", {64, 64, 2});
  LightmapTexels full = pruned;
  const std::vector<uint8_t> mask = scope.probe_mask(pruned.samples);
  const LeakReport a = fix_leaks(pruned, query, {}, {}, &mask);
  const LeakReport b = fix_leaks(full, query, {});
  EXPECT_GT(b.moved + b.invalidated, 0u);  // there are leaks to fix
  EXPECT_EQ(a.moved, b.moved);
  EXPECT_EQ(a.invalidated, b.invalidated);
  EXPECT_EQ(a.texels_invalidated, b.texels_invalidated);
  ASSERT_EQ(pruned.samples.size(), full.samples.size());
  for (size_t j = 0; j < full.samples.size(); ++j) EXPECT_EQ(pruned.samples[j].position, full.samples[j].position);
  // The floor is 64 texels of 1/32 m; the wall's box grown by a texel spans 0.2 + 2/32 m of its 2 m: about 13 % of
  // the samples are probed (0.26 / 2), the rest pruned.
  EXPECT_GT(a.pruned, a.samples * 8 / 10);
  EXPECT_LT(a.pruned, a.samples * 92 / 100);
  EXPECT_LT(a.rays * 4, b.rays);
}

}  // namespace
}  // namespace kiln::lightmap
