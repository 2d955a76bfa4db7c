// Scene validation: each kind of problem, planted in hand-built meshes at known triangles, is found at exactly those
// indices, and the cleaned scene drops (or stops baking) exactly those triangles and nothing else.
#include "bakers/scene/scene_check.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <set>
#include <utility>
#include <vector>

namespace kiln::scene {
namespace {

Instance instance(int mesh, const std::string& lightmap = {}) {
  Instance i;
  i.mesh = mesh;
  i.lightmap = lightmap;
  return i;
}

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::vector<const Problem*> of_kind(const SceneReport& r, ProblemKind k) {
  std::vector<const Problem*> out;
  for (const Problem& p : r.problems)
    if (p.kind == k) out.push_back(&p);
  return out;
}

// Ten separate triangles (vertices 3k, 3k+1, 3k+2), triangle k at x = 2k, its lightmap UVs in cell k of a 4×4 grid
// with a margin, so no two overlap.
Mesh strip(const std::string& name, int count = 10) {
  Mesh m;
  m.name = name;
  for (int k = 0; k < count; ++k) {
    const double x = 2.0 * k;
    m.positions.insert(m.positions.end(), {{x, 0, 0}, {x + 1, 0, 0}, {x, 1, 0}});
    m.normals.insert(m.normals.end(), 3, Vec3{0, 0, 1});
    m.uv.insert(m.uv.end(), {{0, 0}, {1, 0}, {0, 1}});
    const double u0 = (k % 4) * 0.25 + 0.02, v0 = (k / 4) * 0.25 + 0.02;
    m.lightmap_uv.insert(m.lightmap_uv.end(), {{u0, v0}, {u0 + 0.2, v0}, {u0, v0 + 0.2}});
    m.indices.insert(m.indices.end(), {uint32_t(3 * k), uint32_t(3 * k + 1), uint32_t(3 * k + 2)});
    m.material.push_back(k % 2);
  }
  return m;
}

Scene base_scene() {
  Scene s;
  s.materials.resize(2);
  s.materials[0].name = "a";
  s.materials[1].name = "b";
  return s;
}

TEST(SceneCheck, CleanSceneHasNoProblemsAndKeepsEverything) {
  Scene s = base_scene();
  s.meshes.push_back(strip("clean"));
  s.instances.push_back({});
  const CheckedScene c = check_scene(s);
  EXPECT_TRUE(c.report.clean()) << c.report.summary();
  ASSERT_EQ(c.scene.meshes.size(), 1u);
  EXPECT_EQ(c.scene.meshes[0].indices, s.meshes[0].indices);
  EXPECT_EQ(c.triangles[0].source_triangle, (std::vector<uint32_t>{0, 1, 2, 3, 4, 5, 6, 7, 8, 9}));
  EXPECT_EQ(c.triangles[0].bake, std::vector<uint8_t>(10, 1));
  ASSERT_EQ(c.scene.instances.size(), 1u);
  EXPECT_EQ(c.scene.instances[0].lightmap, "clean");  // resolved from the mesh name
  EXPECT_TRUE(c.scene.instances[0].bake);
}

TEST(SceneCheck, TriangleProblemsAtTheirIndices) {
  Scene s = base_scene();
  s.meshes.push_back(strip("good"));
  Mesh m = strip("bad");
  m.indices[3 * 1 + 2] = 999;                      // triangle 1: index out of range
  m.positions[3 * 2 + 1] = {kNaN, 0, 0};           // triangle 2: NaN vertex
  m.positions[3 * 3 + 2] = {2.0 * 3 + 0.5, 0, 0};  // triangle 3: collinear (zero area)
  m.lightmap_uv[3 * 4 + 1] = {1.25, 0.1};          // triangle 4: lightmap UV outside [0,1]
  m.lightmap_uv[3 * 5 + 2] = {m.lightmap_uv[3 * 5 + 1].x - 0.1, m.lightmap_uv[3 * 5 + 1].y};  // 5: UVs collinear
  m.material[6] = 7;           // triangle 6: material out of range (2 materials)
  for (int c = 0; c < 3; ++c)  // triangle 8's UVs: triangle 7's, shifted by (-0.03, 0.03)
    m.lightmap_uv[3 * 8 + c] = {m.lightmap_uv[3 * 7 + c].x - 0.03, m.lightmap_uv[3 * 7 + c].y + 0.03};
  m.positions[3 * 9] = {INFINITY, 0, 0};  // triangle 9: infinite vertex
  m.normals[0] = {0, 0, 0};               // vertex 0 (triangle 0): zero normal
  m.normals[4] = {kNaN, 0, 1};            // vertex 4 (triangle 1, dropped): NaN normal
  m.uv[1] = {kNaN, 0.5};                  // vertex 1: NaN texture UV
  s.meshes.push_back(m);
  s.instances.push_back(instance(0));
  s.instances.push_back(instance(1));
  const CheckedScene c = check_scene(s);
  const SceneReport& r = c.report;

  auto expect_one = [&](ProblemKind k, int64_t triangle) {
    const auto ps = of_kind(r, k);
    ASSERT_EQ(ps.size(), 1u) << to_string(k) << "\n" << r.summary();
    EXPECT_EQ(r.count(k), 1);
    EXPECT_EQ(ps[0]->mesh, 1) << to_string(k);
    EXPECT_EQ(ps[0]->triangle, triangle) << to_string(k);
    EXPECT_FALSE(ps[0]->what.empty());
    EXPECT_FALSE(ps[0]->action.empty());
  };
  expect_one(ProblemKind::index_out_of_range, 1);
  expect_one(ProblemKind::degenerate_triangle, 3);
  expect_one(ProblemKind::lightmap_uv_out_of_range, 4);
  expect_one(ProblemKind::degenerate_lightmap_uv, 5);
  expect_one(ProblemKind::material_out_of_range, 6);
  expect_one(ProblemKind::overlapping_lightmap_uv, 7);
  EXPECT_EQ(of_kind(r, ProblemKind::overlapping_lightmap_uv)[0]->other_triangle, 8);
  const auto nf = of_kind(r, ProblemKind::non_finite_vertex);  // triangle 2 (NaN) and triangle 9 (infinite)
  ASSERT_EQ(nf.size(), 2u);
  EXPECT_EQ(nf[0]->triangle, 2);
  EXPECT_EQ(nf[1]->triangle, 9);
  EXPECT_EQ(r.count(ProblemKind::bad_normal), 2);
  EXPECT_EQ(r.count(ProblemKind::non_finite_uv), 1);
  EXPECT_EQ(of_kind(r, ProblemKind::non_finite_uv)[0]->vertex, 1);

  // The cleaned mesh: triangles 1, 2, 3 and 9 dropped; 4 and 5 traced but not baked; the rest baked.
  const Mesh& cm = c.scene.meshes[1];
  EXPECT_EQ(c.triangles[1].source_triangle, (std::vector<uint32_t>{0, 4, 5, 6, 7, 8}));
  EXPECT_EQ(c.triangles[1].bake, (std::vector<uint8_t>{1, 0, 0, 1, 1, 1}));
  ASSERT_EQ(cm.indices.size(), 18u);
  for (size_t t = 0; t < 6; ++t)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(cm.indices[3 * t + k], m.indices[3 * c.triangles[1].source_triangle[t] + k]);
  ASSERT_EQ(cm.material.size(), 6u);
  EXPECT_EQ(cm.material[3], 0u);  // triangle 6's material 7 → 0
  EXPECT_EQ(cm.material[1], 0u);  // triangle 4 keeps its own (4 % 2)
  EXPECT_EQ(cm.material[4], 1u);  // triangle 7 keeps its own (7 % 2)
  // The zero normal of vertex 0 became triangle 0's geometric normal, +z (counter-clockwise in the xy-plane).
  EXPECT_EQ(cm.normals[0], (Vec3{0, 0, 1}));
  EXPECT_EQ(cm.uv[1].x, 0.0);
  for (const Vec3& p : cm.positions) EXPECT_TRUE(is_finite(p));  // nothing non-finite left, referenced or not
  // The good mesh is untouched.
  EXPECT_EQ(c.triangles[0].source_triangle.size(), 10u);
  // The overlap between triangles of "bad" is the only one: the good mesh bakes into its own lightmap.
  EXPECT_EQ(r.count(ProblemKind::overlapping_lightmap_uv), 1);
}

TEST(SceneCheck, BothNonFiniteVerticesReported) {
  Scene s = base_scene();
  Mesh m = strip("m", 4);
  m.positions[3 * 1] = {kNaN, 0, 0};
  m.positions[3 * 3 + 2] = {0, -INFINITY, 0};
  s.meshes.push_back(m);
  const CheckedScene c = check_scene(s);
  const auto ps = of_kind(c.report, ProblemKind::non_finite_vertex);
  ASSERT_EQ(ps.size(), 2u);
  EXPECT_EQ(ps[0]->triangle, 1);
  EXPECT_EQ(ps[1]->triangle, 3);
  EXPECT_EQ(c.triangles[0].source_triangle, (std::vector<uint32_t>{0, 2}));
}

TEST(SceneCheck, MeshLevelProblems) {
  Scene s = base_scene();
  Mesh no_lm = strip("no_lightmap", 2);
  no_lm.lightmap_uv.clear();
  Mesh bad_normals = strip("bad_arrays", 3);
  bad_normals.normals.pop_back();    // 8 normals for 9 positions
  bad_normals.uv.push_back({0, 0});  // 10 UVs
  bad_normals.material.pop_back();   // 2 materials for 3 triangles
  bad_normals.indices.push_back(0);  // 10 indices
  Mesh bad_lm = strip("bad_lightmap_uv", 2);
  bad_lm.lightmap_uv.pop_back();
  s.meshes = {no_lm, bad_normals, bad_lm};
  for (int i = 0; i < 3; ++i) s.instances.push_back(instance(i));
  const CheckedScene c = check_scene(s);
  const SceneReport& r = c.report;

  const auto no = of_kind(r, ProblemKind::no_lightmap_uv);
  ASSERT_EQ(no.size(), 1u);
  EXPECT_EQ(no[0]->mesh, 0);
  const auto sizes = of_kind(r, ProblemKind::array_size_mismatch);
  ASSERT_EQ(sizes.size(), 4u) << r.summary();  // normals, uv, material of mesh 1; lightmap_uv of mesh 2
  EXPECT_EQ(sizes[0]->mesh, 1);
  EXPECT_EQ(sizes[3]->mesh, 2);
  const auto count = of_kind(r, ProblemKind::index_count);
  ASSERT_EQ(count.size(), 1u);
  EXPECT_EQ(count[0]->mesh, 1);

  // Traced but not baked: meshes 0 and 2 have no usable lightmap UVs.
  EXPECT_EQ(c.triangles[0].bake, (std::vector<uint8_t>{0, 0}));
  EXPECT_EQ(c.triangles[2].bake, (std::vector<uint8_t>{0, 0}));
  EXPECT_FALSE(c.scene.instances[0].bake);
  EXPECT_TRUE(c.scene.instances[1].bake);
  EXPECT_FALSE(c.scene.instances[2].bake);
  // Mesh 1: the trailing index ignored, its 3 triangles kept; mismatched arrays dropped (material 0 everywhere).
  EXPECT_EQ(c.scene.meshes[1].indices.size(), 9u);
  EXPECT_TRUE(c.scene.meshes[1].normals.empty());
  EXPECT_TRUE(c.scene.meshes[1].uv.empty());
  EXPECT_TRUE(c.scene.meshes[1].material.empty());
}

TEST(SceneCheck, InstanceProblemsSkipOrUnbakeThatInstance) {
  Scene s = base_scene();
  s.meshes.push_back(strip("m", 2));
  Instance ok = instance(0);
  Instance singular = instance(0);
  singular.to_world.m[5] = 0;  // y scaled to 0
  Instance nan = instance(0);
  nan.to_world.m[3] = kNaN;
  Instance missing = instance(3);
  Instance bad_st = instance(0, "other");
  bad_st.lightmap_scale_offset = {0.5, 0.5, 0.75, 0};  // u range [0.75, 1.25]
  s.instances = {ok, singular, nan, missing, bad_st};
  const CheckedScene c = check_scene(s);
  const SceneReport& r = c.report;
  const auto bt = of_kind(r, ProblemKind::bad_transform);
  ASSERT_EQ(bt.size(), 2u);
  EXPECT_EQ(bt[0]->instance, 1);
  EXPECT_EQ(bt[1]->instance, 2);
  const auto bm = of_kind(r, ProblemKind::bad_instance_mesh);
  ASSERT_EQ(bm.size(), 1u);
  EXPECT_EQ(bm[0]->instance, 3);
  const auto st = of_kind(r, ProblemKind::bad_lightmap_scale_offset);
  ASSERT_EQ(st.size(), 1u);
  EXPECT_EQ(st[0]->instance, 4);
  EXPECT_EQ(c.source_instance, (std::vector<uint32_t>{0, 4}));
  EXPECT_TRUE(c.scene.instances[0].bake);
  EXPECT_FALSE(c.scene.instances[1].bake);  // kept for shadows, not baked
}

TEST(SceneCheck, UsableTransform) {
  Transform t;
  EXPECT_TRUE(usable_transform(t));
  t.m[0] = -1;  // a mirror is fine
  EXPECT_TRUE(usable_transform(t));
  t.m = {1e-7, 0, 0, 0, 0, 1e-7, 0, 0, 0, 0, 1e-7, 0};  // uniformly tiny: well conditioned
  EXPECT_TRUE(usable_transform(t));
  t.m = {1, 1, 0, 0, 0, 1e-13, 0, 0, 0, 0, 1, 0};  // columns 0 and 1 parallel to 1e-13: singular
  EXPECT_FALSE(usable_transform(t));
  t.m = {1, 0, 0, INFINITY, 0, 1, 0, 0, 0, 0, 1, 0};
  EXPECT_FALSE(usable_transform(t));
}

TEST(SceneCheck, MaterialsAndTextures) {
  Scene s;  // no materials
  s.meshes.push_back(strip("m", 1));
  Texture short_texture;
  short_texture.width = 2;
  short_texture.height = 2;
  short_texture.texels.resize(3);  // 3 texels for 2×2
  s.textures.push_back(short_texture);
  const CheckedScene c0 = check_scene(s);
  EXPECT_EQ(c0.report.count(ProblemKind::no_materials), 1);
  ASSERT_EQ(c0.scene.materials.size(), 1u);
  // Mesh material 1 of the one default material: out of range → 0.
  EXPECT_EQ(c0.report.count(ProblemKind::material_out_of_range), 0);  // strip's triangle 0 has material 0

  s.materials.resize(2);
  s.materials[0].base_color_texture = 0;  // 3 texels for 2×2
  s.materials[1].base_color_texture = 5;  // no such texture
  const CheckedScene c1 = check_scene(s);
  EXPECT_EQ(c1.report.count(ProblemKind::bad_texture), 2);
  EXPECT_FALSE(c1.scene.materials[0].base_color_texture.has_value());
  EXPECT_FALSE(c1.scene.materials[1].base_color_texture.has_value());
}

// Colours that are not a reflectance or a radiance are repaired and reported, never passed on: a base colour per
// channel (NaN and negatives → 0, above 1 → 1), an emission as a whole when a channel is not finite.
TEST(SceneCheck, BadMaterialValuesAreRepairedAndReported) {
  Scene s;
  s.meshes.push_back(strip("m", 1));
  s.materials.resize(4);
  const double nan = std::nan("");
  s.materials[0].base_color = Rgb{0.5, nan, 2.0};
  s.materials[1].emission = Rgb{1.0, nan, 1.0};
  s.materials[2].emission = Rgb{2.0, -1.0, 3.0};
  s.materials[3].base_color = Rgb{0.2, 0.3, 0.4};  // fine: untouched
  const CheckedScene c = check_scene(s);
  EXPECT_EQ(c.report.count(ProblemKind::bad_material_value), 3);
  EXPECT_EQ(c.scene.materials[0].base_color, (Rgb{0.5, 0.0, 1.0}));
  EXPECT_EQ(c.scene.materials[1].emission, Rgb{0.0});
  EXPECT_EQ(c.scene.materials[2].emission, (Rgb{2.0, 0.0, 3.0}));
  EXPECT_EQ(c.scene.materials[3].base_color, (Rgb{0.2, 0.3, 0.4}));
}

// A grid of n×n quads whose lightmap UVs are its positions scaled into [0,1]: adjacent triangles share edges and
// vertices exactly, which must not count as overlap.
Mesh grid(int n) {
  Mesh m;
  m.name = "grid";
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      m.positions.push_back({double(i), 0, double(j)});
      m.lightmap_uv.push_back({double(i) / n, double(j) / n});
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const uint32_t a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      m.indices.insert(m.indices.end(), {a, c, b, b, c, d});
    }
  return m;
}

TEST(SceneCheck, OverlapFindsExactlyThePlantedPairsInALargeMesh) {
  constexpr int n = 150;  // 45,000 triangles: a quadratic pair test would take ~1e9 tests; the grid takes ~1e5
  Scene s = base_scene();
  Mesh m = grid(n);
  EXPECT_TRUE(check_scene([&] {
                Scene t = s;
                t.meshes.push_back(m);
                t.instances.push_back({});
                return t;
              }())
                  .report.clean());
  // Plant one small triangle strictly inside the lower-left triangle of quad (10, 20), and one across the diagonal
  // of quad (100, 40): one and two overlapping pairs.
  const double h = 1.0 / n;
  auto add = [&](Point2 a, Point2 b, Point2 c) {
    const uint32_t base = static_cast<uint32_t>(m.positions.size());
    m.positions.insert(m.positions.end(), {{0, 1, 0}, {1, 1, 0}, {0, 1, 1}});
    m.lightmap_uv.insert(m.lightmap_uv.end(), {a, b, c});
    m.indices.insert(m.indices.end(), {base, base + 1, base + 2});
  };
  add({10.1 * h, 20.1 * h}, {10.3 * h, 20.1 * h}, {10.1 * h, 20.3 * h});
  add({100.3 * h, 40.3 * h}, {100.7 * h, 40.3 * h}, {100.5 * h, 40.7 * h});
  s.meshes.push_back(m);
  s.instances.push_back({});
  const CheckedScene c = check_scene(s);
  const auto ps = of_kind(c.report, ProblemKind::overlapping_lightmap_uv);
  ASSERT_EQ(c.report.count(ProblemKind::overlapping_lightmap_uv), 3) << c.report.summary();
  const int64_t first = 2LL * n * n, second = first + 1;
  std::set<std::pair<int64_t, int64_t>> pairs;
  for (const Problem* p : ps) pairs.insert(std::minmax(p->triangle, p->other_triangle));
  // Quad (i, j) holds triangles 2(jn + i) (a, c, b: the lower-left half, u + v below the diagonal) and 2(jn + i) + 1.
  const int64_t q1 = 2LL * (20 * n + 10), q2 = 2LL * (40 * n + 100);
  EXPECT_EQ(pairs, (std::set<std::pair<int64_t, int64_t>>{{q1, first}, {q2, second}, {q2 + 1, second}}));
}

TEST(SceneCheck, InstancesSharingALightmapOverlapUnlessTheirRectanglesAreDisjoint) {
  Scene s = base_scene();
  s.meshes.push_back(strip("m", 3));
  s.instances = {instance(0, "atlas"), instance(0, "atlas")};
  const CheckedScene same = check_scene(s);
  // Every triangle of one instance lies on the same triangle of the other: 3 pairs.
  EXPECT_EQ(same.report.count(ProblemKind::overlapping_lightmap_uv), 3);
  for (const Problem* p : of_kind(same.report, ProblemKind::overlapping_lightmap_uv)) {
    EXPECT_EQ(p->triangle, p->other_triangle);
    EXPECT_NE(p->instance, p->other_instance);
  }
  s.instances[0].lightmap_scale_offset = {0.5, 1, 0, 0};
  s.instances[1].lightmap_scale_offset = {0.5, 1, 0.5, 0};
  EXPECT_EQ(check_scene(s).report.count(ProblemKind::overlapping_lightmap_uv), 0);
}

TEST(SceneCheck, ListingIsBoundedButCountingIsNot) {
  Scene s = base_scene();
  Mesh m = strip("m", 300);
  for (int k = 0; k < 300; ++k) m.positions[3 * k + 2] = m.positions[3 * k + 1];  // all degenerate
  s.meshes.push_back(m);
  CheckOptions options;
  options.max_listed_per_kind = 10;
  const CheckedScene c = check_scene(s, options);
  EXPECT_EQ(c.report.count(ProblemKind::degenerate_triangle), 300);
  EXPECT_EQ(of_kind(c.report, ProblemKind::degenerate_triangle).size(), 10u);
  EXPECT_TRUE(c.scene.meshes[0].indices.empty());
  EXPECT_NE(c.report.summary().find("300 x degenerate_triangle (10 listed)"), std::string::npos);
}

TEST(SceneCheck, SliverThresholdIsRelative) {
  // The same sliver shape at two scales: the verdict must not depend on the scene's unit.
  for (double scale : {1e-6, 1.0, 1e6}) {
    Scene s = base_scene();
    Mesh m;
    m.positions = {{0, 0, 0}, {scale, 0, 0}, {0.5 * scale, 1e-4 * scale, 0},   // thin but valid (1e-4)
                   {0, 0, 0}, {scale, 0, 0}, {0.5 * scale, 1e-8 * scale, 0}};  // flat at float precision
    m.indices = {0, 1, 2, 3, 4, 5};
    s.meshes.push_back(m);
    const CheckedScene c = check_scene(s);
    const auto ps = of_kind(c.report, ProblemKind::degenerate_triangle);
    ASSERT_EQ(ps.size(), 1u) << "scale " << scale;
    EXPECT_EQ(ps[0]->triangle, 1);
  }
}

}  // namespace
}  // namespace kiln::scene
