// Leak probes only where they can matter (leak_scope.h): the mesh properties that rule out a mesh hiding its own
// points (convex, height field), a lone terrain that gets no probe ray at all, and a wall through a floor whose
// leaks are fixed exactly as with every point probed, with probes only near the wall.
#include "bakers/lightmap/leak_scope.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <utility>

#include "bakers/lightmap/leaks.h"
#include "bakers/lightmap/lightmap_bake.h"
#include "bakers/lightmap/texels.h"
#include "bakers/lightmap/tracer_query.h"
#include "bakers/math/constants.h"
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

scene::Mesh sphere_mesh(Vec3 centre, double radius, bool inward = false) {
  scene::Scene s;
  test::add_sphere(s, "ball", centre, radius, 8, 0, inward);
  return only_mesh(s);
}

// A rock: a lat-long surface with a seam column of its own, two bumps of ±15 % around it and two along it (not
// convex; its valleys far from 90°).
scene::Mesh rock_mesh() {
  return bench::level_detail::lat_long(
      "rock", 8, 16, [](int j, int i) { return 1.0 + 0.15 * std::sin(2 * kPi * i / 8) * std::sin(2 * kPi * j / 8); });
}

scene::Mesh merged(const scene::Mesh& a, const scene::Mesh& b) {
  scene::Mesh m = a;
  const uint32_t base = static_cast<uint32_t>(m.positions.size());
  m.positions.insert(m.positions.end(), b.positions.begin(), b.positions.end());
  if (!m.lightmap_uv.empty()) m.lightmap_uv.insert(m.lightmap_uv.end(), b.lightmap_uv.begin(), b.lightmap_uv.end());
  if (!m.normals.empty()) m.normals.insert(m.normals.end(), b.normals.begin(), b.normals.end());
  for (uint32_t i : b.indices) m.indices.push_back(base + i);
  return m;
}

// A rough rock: its radius jittered by ±30 % from vertex to vertex (as the generated level's rocks are), 1 at the
// poles.
scene::Mesh rough_rock_mesh() {
  scene::Mesh m = bench::level_detail::lat_long(
      "rock", 8, 16, [](int j, int i) { return j == 0 || j == 8 ? 1.0 : 1.0 + 0.3 * std::sin(1e3 * (i + 7.1 * j)); });
  m.material.assign(m.indices.size() / 3, 0);
  return m;
}

// The texels' leaks fixed with the mask's probes and with every point probed: the same moves, invalidations and
// positions. Returns {masked, full}.
// Takes away the triangles of the mesh's top (all three corners at its highest y): a box without its lid.
void remove_top_face(scene::Mesh& mesh) {
  double top = -INFINITY;
  for (const Vec3& p : mesh.positions) top = std::max(top, p.y);
  std::vector<uint32_t> kept;
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const bool on_top = mesh.positions[mesh.indices[t]].y == top && mesh.positions[mesh.indices[t + 1]].y == top &&
                        mesh.positions[mesh.indices[t + 2]].y == top;
    if (!on_top) kept.insert(kept.end(), mesh.indices.begin() + t, mesh.indices.begin() + t + 3);
  }
  ASSERT_LT(kept.size(), mesh.indices.size());
  mesh.indices = kept;
}

std::pair<LeakReport, LeakReport> expect_same_leaks_as_probing_all(const LightmapTexels& texels, const RayQuery& query,
                                                                   const std::vector<uint8_t>& mask) {
  LightmapTexels pruned = texels, full = texels;
  const LeakReport a = fix_leaks(pruned, query, {}, {}, &mask);
  const LeakReport b = fix_leaks(full, query, {});
  EXPECT_EQ(a.moved, b.moved);
  EXPECT_EQ(a.invalidated, b.invalidated);
  EXPECT_EQ(a.texels_invalidated, b.texels_invalidated);
  EXPECT_EQ(pruned.samples.size(), full.samples.size());
  for (size_t j = 0; j < std::min(pruned.samples.size(), full.samples.size()); ++j)
    EXPECT_EQ(pruned.samples[j].position, full.samples[j].position);
  return {a, b};
}

// Closed surfaces around a centre they surround once (a sphere, a rippled rock, a box) cannot hide their own points;
// a room (facing in), two shells (one inside the other, or apart), an open hemisphere and a torus can.
TEST(LeakScope, ClosedStarShapedMeshesCannotHideTheirOwnPoints) {
  EXPECT_TRUE(is_star_shaped_closed(sphere_mesh({0, 1, 0}, 1)));
  EXPECT_TRUE(is_star_shaped_closed(rock_mesh()));
  EXPECT_FALSE(is_convex_mesh(rock_mesh()));  // so only this rule spares it its probes
  EXPECT_TRUE(is_star_shaped_closed(box_mesh(false)));
  EXPECT_FALSE(is_star_shaped_closed(box_mesh(true)));
  EXPECT_FALSE(is_star_shaped_closed(sphere_mesh({0, 0, 0}, 1, true)));
  // Two shells: nested, every triangle faces away from the centre but the directions are covered twice (8π);
  // apart, the far sphere's triangles face the centre.
  EXPECT_FALSE(is_star_shaped_closed(merged(sphere_mesh({0, 0, 0}, 1), sphere_mesh({0, 0, 0}, 0.5))));
  EXPECT_FALSE(is_star_shaped_closed(merged(sphere_mesh({-2, 0, 0}, 1), sphere_mesh({2, 0, 0}, 1))));
  scene::Mesh half = sphere_mesh({0, 0, 0}, 1);
  half.indices.resize(half.indices.size() / 2);
  EXPECT_FALSE(is_star_shaped_closed(half));  // open
  // A torus (major radius 2, minor 0.5), closed and outward: its inner side faces the centre.
  scene::Mesh torus;
  constexpr int kU = 24, kV = 12;
  for (int i = 0; i < kU; ++i) {
    for (int j = 0; j < kV; ++j) {
      const double u = 2 * kPi * i / kU, v = 2 * kPi * j / kV;
      torus.positions.push_back(
          {(2 + 0.5 * std::cos(v)) * std::cos(u), 0.5 * std::sin(v), (2 + 0.5 * std::cos(v)) * std::sin(u)});
    }
  }
  for (int i = 0; i < kU; ++i) {
    for (int j = 0; j < kV; ++j) {
      const auto at = [](int a, int b) { return static_cast<uint32_t>((a % kU) * kV + b % kV); };
      torus.indices.insert(torus.indices.end(), {at(i, j), at(i, j + 1), at(i + 1, j + 1)});
      torus.indices.insert(torus.indices.end(), {at(i, j), at(i + 1, j + 1), at(i + 1, j)});
    }
  }
  EXPECT_FALSE(is_star_shaped_closed(torus));
}

// A crate (a 0.6 m box, turned 45° about y) sunk through a floor: its box in world space covers twice its footprint,
// but only the floor's points under it are probed (the crate is closed and convex: a point outside it meets its front
// faces first), and the leaks are fixed as with every point probed. Without its lid the crate is open, and the
// points within a texel of its sides are probed too (one side's plane with a point farther in front puts the point
// outside the whole convex crate).
TEST(LeakScope, TheGroundBesideATurnedCrateIsNotProbed) {
  for (const bool lid : {true, false}) {
    SCOPED_TRACE(lid ? "a closed crate" : "a crate without its lid");
    scene::Scene s;
    s.materials.push_back(test::lambert_material("white", 0.5));
    test::add_floor(s, 2.0, 0, 8);
    test::add_box(s, "crate", {-0.3, -0.5, -0.3}, {0.3, 0.5, 0.3}, 0);
    if (!lid) remove_top_face(s.meshes.back());
    const double c = std::cos(kPi / 4), sn = std::sin(kPi / 4);
    s.instances.back().to_world.m = {c, 0, sn, 0, 0, 1, 0, 0, -sn, 0, c, 0};
    const scene::CheckedScene checked = scene::check_scene(s);
    const scene::Tracer tracer(checked.scene);
    const TracerRayQuery query(tracer, checked.scene);
    const LeakScope scope(checked.scene);
    ASSERT_EQ(scope.summary().convex_meshes, 2u);
    const LightmapTexels pruned = rasterize_lightmap(checked.scene, "floor", {64, 64, 2});
    const std::vector<uint8_t> mask = scope.probe_mask(pruned.samples);
    size_t probed = 0;
    for (size_t j = 0; j < pruned.samples.size(); ++j) {
      const TexelSample& t = pruned.samples[j];
      // The point in the crate's frame (the rotation's inverse), against the crate, grown by the margin on each side
      // when it is open.
      const Vec3& p = t.position;
      const double x = c * p.x - sn * p.z, z = sn * p.x + c * p.z, grown = 0.3 + (lid ? 0.0 : t.texel_world_size);
      probed += mask[j];
      if (std::abs(std::abs(x) - grown) < 1e-9 || std::abs(std::abs(z) - grown) < 1e-9) continue;  // on the edge
      EXPECT_EQ(mask[j] != 0, std::abs(x) < grown && std::abs(z) < grown) << "sample " << j << " at " << x << ", " << z;
    }
    EXPECT_GT(probed, 0u);
    const auto [a, b] = expect_same_leaks_as_probing_all(pruned, query, mask);
    EXPECT_GT(b.moved + b.invalidated, 0u);
  }
}

// A rough rock (rough_rock_mesh) is closed and star-shaped but has valleys sharper than 90°: alone in the scene,
// exactly the points on those valleys' triangles are probed, and its leaks are fixed as with every point probed.
TEST(LeakScope, ARoughRockIsProbedOnlyInItsSharpValleys) {
  scene::Scene s;
  s.materials.push_back(test::lambert_material("stone", 0.5));
  s.meshes.push_back(rough_rock_mesh());
  s.instances.push_back({});
  s.environment.constant = Rgb{1.0};
  const scene::CheckedScene checked = scene::check_scene(s);
  const LeakScope scope(checked.scene);
  ASSERT_EQ(scope.summary().star_shaped_meshes, 1u);
  const std::vector<uint8_t> valleys = sharp_valley_triangles(checked.scene.meshes[0]);
  const size_t flagged = static_cast<size_t>(std::count(valleys.begin(), valleys.end(), 1));
  EXPECT_EQ(scope.summary().valley_triangles, flagged);
  EXPECT_GT(flagged, 0u);
  EXPECT_LT(flagged, valleys.size() / 2);

  const scene::Tracer tracer(checked.scene);
  const TracerRayQuery query(tracer, checked.scene);
  const LightmapTexels pruned = rasterize_lightmap(checked.scene, "rock", {64, 64, 2});
  const std::vector<uint8_t> mask = scope.probe_mask(pruned.samples);
  for (size_t j = 0; j < pruned.samples.size(); ++j)
    EXPECT_EQ(mask[j], valleys[pruned.samples[j].triangle.triangle]) << "sample " << j;
  const auto [a, b] = expect_same_leaks_as_probing_all(pruned, query, mask);
  EXPECT_LT(a.rays * 2, b.rays);
}

// A rough rock sunk 0.3 m into a floor: its box covers a square of the floor, but only the floor's points inside the
// rock are probed, and the leaks are fixed as with every point probed.
TEST(LeakScope, TheGroundAroundARockIsProbedOnlyUnderIt) {
  scene::Scene s;
  s.materials.push_back(test::lambert_material("stone", 0.5));
  test::add_floor(s, 4.0, 0, 8);
  s.meshes.push_back(rough_rock_mesh());
  scene::Instance placed;
  placed.mesh = static_cast<int>(s.meshes.size() - 1);
  placed.to_world = test::translate_scale({0.2, 0.7, -0.1}, 1.0);
  s.instances.push_back(placed);
  const scene::CheckedScene checked = scene::check_scene(s);
  const LeakScope scope(checked.scene);
  ASSERT_EQ(scope.summary().star_shaped_meshes, 1u);
  const std::optional<Vec3> centre = star_centre(checked.scene.meshes[1]);
  ASSERT_TRUE(centre.has_value());
  const scene::Tracer tracer(checked.scene);
  const TracerRayQuery query(tracer, checked.scene);
  const LightmapTexels pruned = rasterize_lightmap(checked.scene, "floor", {64, 64, 2});
  const std::vector<uint8_t> mask = scope.probe_mask(pruned.samples);
  size_t probed = 0;
  for (size_t j = 0; j < pruned.samples.size(); ++j) {
    const Vec3 q = pruned.samples[j].position - Vec3{0.2, 0.7, -0.1};
    EXPECT_EQ(mask[j] != 0, inside_star_shaped(checked.scene.meshes[1], *centre, q)) << "sample " << j;
    probed += mask[j];
  }
  EXPECT_GT(probed, 0u);
  EXPECT_LT(probed, pruned.samples.size() / 2);
  const auto [a, b] = expect_same_leaks_as_probing_all(pruned, query, mask);
  EXPECT_GT(b.moved + b.invalidated, 0u);
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
  // 29 of the 32 rays each: a point with no back face in 29 cannot be inside whatever the last three see (leaks.h).
  EXPECT_EQ(full.rays, 29u * full.samples);
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

  const LightmapTexels pruned = rasterize_lightmap(checked.scene, "floor", {64, 64, 2});
  const std::vector<uint8_t> mask = scope.probe_mask(pruned.samples);
  const auto [a, b] = expect_same_leaks_as_probing_all(pruned, query, mask);
  EXPECT_GT(b.moved + b.invalidated, 0u);  // there are leaks to fix
  // The floor is 64 texels of 1/32 m; the wall's box grown by a texel spans 0.2 + 2/32 m of its 2 m: about 13 % of
  // the samples are probed (0.26 / 2), the rest pruned.
  EXPECT_GT(a.pruned, a.samples * 8 / 10);
  EXPECT_LT(a.pruned, a.samples * 92 / 100);
  EXPECT_LT(a.rays * 4, b.rays);
}

// A rock (a 0.6 × 1.6 × 0.6 m box) standing on a slope (an 8 m quad tilted by 26.6°), sunk into it: the slope's box
// holds the whole rock, but only the rock's points behind the slope's plane or within a texel in front of it can be
// hidden by it, and only those are probed; leaks are fixed exactly as with every point probed. The same with the
// slope's instance mirrored (x → −x: the same surface, its winding reversed by the transform).
TEST(LeakScope, ARockOnASlopeIsProbedOnlyWhereItMeetsTheGround) {
  for (const bool mirrored : {false, true}) {
    SCOPED_TRACE(mirrored ? "slope mirrored" : "slope as modelled");
    scene::Scene s;
    s.materials.push_back(test::lambert_material("white", 0.5));
    // Two triangles, one chunk: its box holds the whole rock, so the planes alone decide (a subdivided slope's
    // chunks would leave the rock's deepest points out of every box, not probed either way).
    test::add_quad(s, "slope", {-4, -2, 4}, {4, -2, 4}, {4, 2, -4}, {-4, 2, -4}, 0, 1);
    if (mirrored) s.instances.back().to_world.m[0] = -1;
    test::add_box(s, "rock", {-0.3, -0.4, -0.3}, {0.3, 1.2, 0.3}, 0);
    const scene::CheckedScene checked = scene::check_scene(s);
    const scene::Tracer tracer(checked.scene);
    const TracerRayQuery query(tracer, checked.scene);
    const LeakScope scope(checked.scene);
    ASSERT_EQ(scope.summary().convex_meshes, 2u);  // only the other instance can hide a point

    const LightmapTexels pruned = rasterize_lightmap(checked.scene, "rock", {64, 64, 2});
    const std::vector<uint8_t> mask = scope.probe_mask(pruned.samples);
    // The slope's front normal (0, 2, 1)/√5 through the origin: a point's height above its plane.
    const Vec3 n = normalize(Vec3{0, 2, 1});
    size_t probed = 0, checked_points = 0;
    for (size_t j = 0; j < pruned.samples.size(); ++j) {
      const TexelSample& t = pruned.samples[j];
      const Vec3& p = t.position;
      ASSERT_TRUE(std::abs(p.x) <= 4 && std::abs(p.y) <= 2 && std::abs(p.z) <= 4);  // inside the slope's box
      const double height = dot(n, p), margin = t.texel_world_size;
      probed += mask[j];
      // Points within rounding of the margin could go either way: 1e-9 m is far below a texel, far above rounding.
      if (std::abs(height - margin) < 1e-9) continue;
      ++checked_points;
      EXPECT_EQ(mask[j] != 0, height < margin) << "sample " << j << " at height " << height;
    }
    EXPECT_GT(checked_points, pruned.samples.size() * 99 / 100);
    // Its bottom is always probed, its top never, its sides below a line about a quarter of the way up.
    EXPECT_GT(probed, pruned.samples.size() / 10);
    EXPECT_LT(probed, pruned.samples.size() / 2);

    const auto [a, b] = expect_same_leaks_as_probing_all(pruned, query, mask);
    EXPECT_GT(b.moved + b.invalidated, 0u);  // the sunk part leaks
  }
}

// A valley across a ridge, y = |x|/4 − z²/2 over 8 m × 8 m in quads of 0.5 m: a height field along +y (its normals'
// mean, by its symmetry) that is not convex, cut into chunks of half a row each, the two halves meeting at the
// valley's floor. Near the ridge, points a few centimetres above the ground are behind the planes of the next row's
// triangles: a plane test alone would probe them.
scene::Mesh valley_mesh() {
  scene::Mesh m;
  m.name = "valley";
  constexpr int n = 16;
  for (int j = 0; j <= n; ++j) {
    for (int i = 0; i <= n; ++i) {
      const double x = -4 + 0.5 * i, z = -4 + 0.5 * j;
      m.positions.push_back({x, std::abs(x) / 4 - z * z / 2, z});
      m.lightmap_uv.push_back({static_cast<double>(i) / n, static_cast<double>(j) / n});
    }
  }
  const auto at = [](int i, int j) { return static_cast<uint32_t>(j * (n + 1) + i); };
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      m.indices.insert(m.indices.end(), {at(i, j), at(i, j + 1), at(i + 1, j + 1)});
      m.indices.insert(m.indices.end(), {at(i, j), at(i + 1, j + 1), at(i + 1, j)});
    }
  }
  return m;
}

// The height of p above the valley's triangle straight under or over it (along y), along that triangle's unit front
// normal; NaN where p's column is within 1e-9 m of a triangle's edge (either triangle could be the one).
double height_above(const scene::Mesh& valley, const Vec3& p) {
  for (size_t t = 0; t < valley.indices.size(); t += 3) {
    const Vec3 &a = valley.positions[valley.indices[t]], &b = valley.positions[valley.indices[t + 1]],
               &c = valley.positions[valley.indices[t + 2]];
    // Signed distances of (p.x, p.z) from the triangle's edges in the xz plane (counter-clockwise seen from +y).
    const auto side = [&](const Vec3& u, const Vec3& v) {
      return ((v.z - u.z) * (p.x - u.x) - (v.x - u.x) * (p.z - u.z)) / std::hypot(v.x - u.x, v.z - u.z);
    };
    const double s0 = side(a, b), s1 = side(b, c), s2 = side(c, a);
    if (std::min({s0, s1, s2}) < -1e-9) continue;
    if (std::min({s0, s1, s2}) < 1e-9) return NAN;
    return dot(normalize(cross(b - a, c - a)), p - a);
  }
  return NAN;
}

// A rock (a 0.6 × 1.08 × 0.6 m box) standing on the valley's floor on the ridge, sunk into it: the valley's chunks'
// boxes hold most of the rock, but only the rock's points below the ground, or within the clearance above it (a
// hundredth of a texel and the ray offset), are probed (from higher up a ray meets the valley's front faces only),
// and leaks are fixed exactly as with every point probed.
// The same with the valley mirrored (x → −x: the same surface, its winding reversed by the transform).
TEST(LeakScope, ARockOnATerrainIsProbedOnlyWhereItMeetsTheGround) {
  for (const bool mirrored : {false, true}) {
    SCOPED_TRACE(mirrored ? "valley mirrored" : "valley as modelled");
    scene::Scene s;
    s.materials.push_back(test::lambert_material("white", 0.5));
    s.meshes.push_back(valley_mesh());
    scene::Instance ground;
    ground.mesh = 0;
    if (mirrored) ground.to_world.m[0] = -1;
    s.instances.push_back(ground);
    test::add_box(s, "rock", {-0.3, -0.08, -0.3}, {0.3, 1.0, 0.3}, 0);
    const scene::CheckedScene checked = scene::check_scene(s);
    const scene::Tracer tracer(checked.scene);
    const TracerRayQuery query(tracer, checked.scene);
    const LeakScope scope(checked.scene);
    ASSERT_EQ(scope.summary().height_field_meshes, 1u);
    ASSERT_EQ(scope.summary().convex_meshes, 1u);

    const LightmapTexels pruned = rasterize_lightmap(checked.scene, "rock", {64, 64, 2});
    const std::vector<uint8_t> mask = scope.probe_mask(pruned.samples);
    size_t probed = 0, checked_points = 0, above = 0;
    for (size_t j = 0; j < pruned.samples.size(); ++j) {
      const TexelSample& t = pruned.samples[j];
      const Vec3& p = t.position;
      const double clearance = LeakScopeOptions{}.height_field_clearance_texels * t.texel_world_size + t.ray_offset;
      const double height = height_above(checked.scene.meshes[0], p);
      probed += mask[j];
      // Within reach of the boxes of the chunks under it (their lowest point: y = −1/8): a deeper point is not probed.
      ASSERT_GT(p.y, -0.125);
      // Within rounding of the clearance, or over an edge: either way. 1e-9 m is far below it, far above rounding.
      if (std::isnan(height) || std::abs(height - clearance) < 1e-9) continue;
      ++checked_points;
      above += height > clearance;
      EXPECT_EQ(mask[j] != 0, height < clearance)
          << "sample " << j << " at height " << height << " (clearance " << clearance << ") at " << p.x << ", " << p.z;
    }
    EXPECT_GT(checked_points, pruned.samples.size() / 2);
    EXPECT_GT(above, checked_points / 2);  // most of the rock stands clear of the ground
    EXPECT_GT(probed, 0u);

    const auto [a, b] = expect_same_leaks_as_probing_all(pruned, query, mask);
    EXPECT_GT(b.moved + b.invalidated, 0u);  // the sunk part leaks
  }
}

}  // namespace
}  // namespace kiln::lightmap
