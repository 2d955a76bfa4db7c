// The lightmap-UV generator (bakers/uvgen/): analytic cases (a plane, a cube), the generated set's invariants (no
// overlap, every UV in [0, 1], every triangle counter-clockwise), determinism, a mirrored character, bad meshes, and
// the padding between charts.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <map>
#include <set>

#include "bakers/uvgen/uv_generator.h"
#include "tests/support/uv_shapes.h"

namespace kiln::uvgen {
namespace {

UvgenOptions options_at(int size, int padding = 4) {
  UvgenOptions o;
  o.pack.size = size;
  o.pack.padding = padding;
  return o;
}

// Every charted triangle's UVs in [0, 1] and counter-clockwise; the scene check finds no overlap.
void expect_valid(const GeneratedUvs& g, const std::string& what) {
  const scene::Mesh& m = g.mesh;
  ASSERT_EQ(m.lightmap_uv.size(), m.positions.size()) << what;
  const MeshAdjacency adj(m, ChartOptions{});
  int64_t charted = 0;
  for (uint32_t t = 0; t < adj.triangle_count(); ++t) {
    if (!adj.usable(t)) continue;
    ++charted;
    const Point2 q[3] = {m.lightmap_uv[m.indices[3 * t]], m.lightmap_uv[m.indices[3 * t + 1]],
                         m.lightmap_uv[m.indices[3 * t + 2]]};
    for (const Point2& p : q) {
      ASSERT_TRUE(p.x >= 0 && p.x <= 1 && p.y >= 0 && p.y <= 1) << what << " triangle " << t;
    }
    EXPECT_GT((q[1].x - q[0].x) * (q[2].y - q[0].y) - (q[2].x - q[0].x) * (q[1].y - q[0].y), 0)
        << what << " triangle " << t;
  }
  EXPECT_EQ(g.stats.quality.overlaps, 0) << what;
  EXPECT_EQ(g.stats.quality.flipped, 0) << what;
  EXPECT_EQ(charted, g.stats.quality.triangles) << what;
  EXPECT_TRUE(unusable_lightmap_uvs(m).empty()) << what << ": " << unusable_lightmap_uvs(m);
}

TEST(UvGenerator, PlaneIsOneChartWithoutDistortion) {
  const GeneratedUvs g = generate_lightmap_uvs(test::uv_plane(8, 2.0), options_at(128));
  expect_valid(g, "plane");
  EXPECT_EQ(g.stats.charts, 1);
  EXPECT_EQ(g.stats.vertices_added, 0);
  // A flat chart maps isometrically (up to scale): stretch 1 and angle error 0 up to the solver's rounding
  // (LSCM's conjugate gradient stops at a relative residual near 1e-10; 1e-6 leaves room).
  EXPECT_NEAR(g.stats.quality.l2_stretch, 1.0, 1e-6);
  EXPECT_NEAR(g.stats.quality.mean_angle_error_degrees, 0.0, 1e-4);
}

// The six faces of a cube are six charts, each exactly its face (its two triangles), whether the cube's hard edges
// are written as split normals or only as 90° dihedral angles.
TEST(UvGenerator, CubeChartsFollowItsHardEdges) {
  for (bool split : {true, false}) {
    const scene::Mesh cube = test::uv_cube(split);
    const GeneratedUvs g = generate_lightmap_uvs(cube, options_at(64));
    expect_valid(g, split ? "split cube" : "welded cube");
    EXPECT_EQ(g.stats.charts, 6) << split;
    EXPECT_NEAR(g.stats.quality.l2_stretch, 1.0, 1e-6);
    const MeshAdjacency adj(cube, ChartOptions{});
    const std::vector<Chart> charts = grow_charts(adj, ChartOptions{});
    ASSERT_EQ(charts.size(), 6u);
    for (const Chart& c : charts) {
      ASSERT_EQ(c.size(), 2u);
      EXPECT_NEAR(dot(adj.normal(c[0]), adj.normal(c[1])), 1.0, 1e-12);
    }
  }
}

TEST(UvGenerator, GeneratedSetHasNoOverlapAndBoundedStretch) {
  for (const test::NamedMesh& s : test::uv_generated_set()) {
    if (s.name == "scan_100k") continue;  // the benchmark's; its little sibling below keeps this test fast
    const GeneratedUvs g = generate_lightmap_uvs(s.mesh, options_at(512));
    expect_valid(g, s.name);
    // Every chart was flattened within the bound (1.25), so the mesh's stretch is within it too.
    EXPECT_LE(g.stats.quality.l2_stretch, 1.25) << s.name;
    EXPECT_GT(g.stats.quality.utilisation, 0.3) << s.name;
  }
  const GeneratedUvs scan = generate_lightmap_uvs(test::uv_scan(8000), options_at(512));
  expect_valid(scan, "scan 8k");
}

TEST(UvGenerator, SameMeshSameBytes) {
  const scene::Mesh blob = test::uv_blob();
  const GeneratedUvs a = generate_lightmap_uvs(blob, options_at(256));
  const GeneratedUvs b = generate_lightmap_uvs(blob, options_at(256));
  ASSERT_EQ(a.mesh.lightmap_uv.size(), b.mesh.lightmap_uv.size());
  EXPECT_EQ(
      0, std::memcmp(a.mesh.lightmap_uv.data(), b.mesh.lightmap_uv.data(), a.mesh.lightmap_uv.size() * sizeof(Point2)));
  EXPECT_EQ(a.mesh.indices, b.mesh.indices);
  EXPECT_EQ(a.mesh.positions.size(), b.mesh.positions.size());
}

// A symmetric character whose texture UVs mirror (and stand in for its lightmap UVs): the scene check finds its own
// UVs overlapping, and the generated ones do not.
TEST(UvGenerator, MirroredCharacterGetsSeparateUvs) {
  const scene::Mesh blob = test::uv_blob(true);
  const std::string why = unusable_lightmap_uvs(blob);
  EXPECT_NE(why.find("overlap"), std::string::npos) << why;
  const GeneratedUvs g = generate_lightmap_uvs(blob, options_at(256));
  expect_valid(g, "mirrored blob");
}

// Out-of-range indices, NaN positions, zero-area triangles, a stray index: no crash; the good triangles charted.
TEST(UvGenerator, BadMeshesDoNotCrash) {
  scene::Mesh m = test::uv_plane(2);
  const auto n = static_cast<uint32_t>(m.positions.size());
  m.positions.push_back({NAN, 0, 0});
  m.indices.insert(m.indices.end(), {0, 1, n});      // a NaN corner
  m.indices.insert(m.indices.end(), {0, 1, n + 7});  // out of range
  m.indices.insert(m.indices.end(), {0, 0, 1});      // zero area
  m.indices.insert(m.indices.end(), {0, 1, 2});      // collinear: the grid's first row
  m.indices.push_back(3);                            // not a whole triangle
  const GeneratedUvs g = generate_lightmap_uvs(m, options_at(64));
  EXPECT_EQ(g.stats.quality.overlaps, 0);
  EXPECT_EQ(g.stats.triangles_uncharted, 4);
  EXPECT_EQ(g.stats.quality.triangles, 8);

  const GeneratedUvs empty = generate_lightmap_uvs(scene::Mesh{}, options_at(64));
  EXPECT_EQ(empty.stats.charts, 0);
  EXPECT_TRUE(empty.mesh.lightmap_uv.empty());
}

// Charts are at least `padding` texels apart in the square they were packed for: no bilinear lookup mixes two.
TEST(UvGenerator, ChartsArePaddingTexelsApart) {
  const int size = 64, padding = 4;
  const scene::Mesh cube = test::uv_cube(true);
  const GeneratedUvs g = generate_lightmap_uvs(cube, options_at(size, padding));
  ASSERT_EQ(g.stats.charts, 6);
  EXPECT_EQ(g.stats.pack.size, size);
  // The charts are the faces: two triangles each, in order.
  struct Box {
    double x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY;
  };
  std::vector<Box> boxes(6);
  for (size_t t = 0; t < 12; ++t) {
    for (int c = 0; c < 3; ++c) {
      const Point2 p = g.mesh.lightmap_uv[g.mesh.indices[3 * t + c]];
      Box& b = boxes[t / 2];
      b.x0 = std::min(b.x0, p.x * size), b.x1 = std::max(b.x1, p.x * size);
      b.y0 = std::min(b.y0, p.y * size), b.y1 = std::max(b.y1, p.y * size);
    }
  }
  for (int i = 0; i < 6; ++i) {
    for (int j = i + 1; j < 6; ++j) {
      const double gap = std::max(
          {boxes[j].x0 - boxes[i].x1, boxes[i].x0 - boxes[j].x1, boxes[j].y0 - boxes[i].y1, boxes[i].y0 - boxes[j].y1});
      EXPECT_GE(gap, padding - 1e-9) << i << " " << j;
    }
  }
}

TEST(UvGenerator, UsableUvsAreRecognised) {
  scene::Mesh plane = test::uv_plane(4);
  EXPECT_EQ(unusable_lightmap_uvs(plane), "no lightmap UVs");
  plane.lightmap_uv = plane.uv;
  EXPECT_EQ(unusable_lightmap_uvs(plane), "");
  for (Point2& p : plane.lightmap_uv) p.x *= 2;  // tiling texture UVs
  EXPECT_NE(unusable_lightmap_uvs(plane).find("leave [0, 1]"), std::string::npos);
}

}  // namespace
}  // namespace kiln::uvgen
