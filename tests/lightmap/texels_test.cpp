// Rasterization of lightmap UVs into texel sample points: coverage against hand-computed areas and an independent
// clip (the texel square clipped by the triangle's edges, the reverse of the rasterizer's clip), sample points on
// their triangles and in their texels, world-space frames under instance transforms, bad input, and a timing print.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <map>
#include <set>

#include "bakers/lightmap/memory.h"
#include "bakers/lightmap/texels.h"
#include "bakers/math/rng.h"

namespace kiln::lightmap {
namespace {

// Polygon clips are exact up to rounding of O(10) operations on numbers ≤ a few texels: ~10⁻¹⁵. The brief asks for
// 10⁻¹² (three orders of margin, still far below any coverage that matters).
constexpr double kClipTol = 1e-12;

// A mesh lying in the y = 0 plane with position (u, 0, v)·size per vertex, lightmap UVs as given.
scene::Scene plane_scene(const std::vector<Point2>& uv, const std::vector<uint32_t>& indices, double size = 1.0) {
  scene::Scene s;
  scene::Mesh m;
  m.name = "plane";
  for (const Point2& q : uv) m.positions.push_back({q.x * size, 0.0, q.y * size});
  m.lightmap_uv = uv;
  m.indices = indices;
  s.meshes.push_back(m);
  s.instances.push_back({});
  s.materials.push_back({});
  return s;
}

std::map<std::pair<int, int>, double> coverage(const LightmapTexels& t) {
  std::map<std::pair<int, int>, double> out;
  for (int y = 0; y < t.height; ++y) {
    for (int x = 0; x < t.width; ++x) {
      if (!t.valid(x, y)) continue;
      double sum = 0;
      for (const TexelSample& s : t.at(x, y)) sum += s.weight;
      out[{x, y}] = sum;
    }
  }
  return out;
}

TEST(Texels, RightTriangleCoversTheTexelsBelowTheDiagonal) {
  // UV (0,0), (1,0), (0,1) on 4×4: texel space (0,0), (4,0), (0,4), the half-plane x + y ≤ 4. Texel (x, y) is inside
  // when x + y + 2 ≤ 4, cut in half by the diagonal when x + y = 3, and touches it at a corner only when x + y = 4.
  const auto s = plane_scene({{0, 0}, {1, 0}, {0, 1}}, {0, 1, 2});
  const LightmapTexels t = rasterize_lightmap(s, "plane", {4, 4, 2});
  const auto cov = coverage(t);
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 4; ++x) {
      SCOPED_TRACE(testing::Message() << "texel " << x << "," << y);
      if (x + y <= 2) {
        ASSERT_TRUE(cov.count({x, y}));
        EXPECT_NEAR(cov.at({x, y}), 1.0, kClipTol);
        EXPECT_EQ(t.at(x, y).size(), 4u);  // the whole 2×2 pattern
      } else if (x + y == 3) {
        ASSERT_TRUE(cov.count({x, y}));
        EXPECT_NEAR(cov.at({x, y}), 0.5, kClipTol);
        // Pattern points (x+¼, y+¼) is inside; (x+¾, y+¼) and (x+¼, y+¾) lie on the diagonal (inside, inclusive).
        EXPECT_EQ(t.at(x, y).size(), 3u);
      } else {
        EXPECT_FALSE(cov.count({x, y}));
      }
    }
  }
  EXPECT_EQ(t.report.rasterized, 1u);
  EXPECT_EQ(t.report.skipped_total(), 0u);
}

TEST(Texels, SquareChartAlignedWithTheGridCoversExactlyItsTexels) {
  // [0.25, 0.75]² on 8×8 is texel space [2, 6]²: texels 2..5 in each direction, each covered by the two triangles
  // together exactly once; texels 1 and 6 touch its edges with zero area and are not covered.
  const auto s = plane_scene({{0.25, 0.25}, {0.75, 0.25}, {0.75, 0.75}, {0.25, 0.75}}, {0, 1, 2, 0, 2, 3});
  const LightmapTexels t = rasterize_lightmap(s, "plane", {8, 8, 2});
  const auto cov = coverage(t);
  EXPECT_EQ(cov.size(), 16u);
  for (int y = 2; y <= 5; ++y) {
    for (int x = 2; x <= 5; ++x) EXPECT_NEAR(cov.at({x, y}), 1.0, kClipTol) << x << "," << y;
  }
  EXPECT_EQ(t.report.overlapping_texels, 0u);
}

TEST(Texels, SquareChartOffTheGridCoversTheClippedFractions) {
  // [0.2, 0.65]² on 8×8 is texel space [1.6, 5.2]²: per axis texel 1 is covered 0.4, texels 2..4 fully, texel 5 0.2;
  // the coverage of texel (x, y) is the product.
  const auto s = plane_scene({{0.2, 0.2}, {0.65, 0.2}, {0.65, 0.65}, {0.2, 0.65}}, {0, 1, 2, 0, 2, 3});
  const LightmapTexels t = rasterize_lightmap(s, "plane", {8, 8, 3});
  const auto axis = [](int i) { return i == 1 ? 0.4 : i == 5 ? 0.2 : (i >= 2 && i <= 4) ? 1.0 : 0.0; };
  const auto cov = coverage(t);
  EXPECT_EQ(cov.size(), 25u);
  for (int y = 0; y < 8; ++y) {
    for (int x = 0; x < 8; ++x) {
      const double expected = axis(x) * axis(y);
      if (expected == 0) {
        EXPECT_FALSE(cov.count({x, y})) << x << "," << y;
      } else {
        ASSERT_TRUE(cov.count({x, y})) << x << "," << y;
        // 0.2 and 0.65 are not binary fractions: the edges sit within an ulp of 1.6 and 5.2.
        EXPECT_NEAR(cov.at({x, y}), expected, kClipTol) << x << "," << y;
      }
    }
  }
}

// The reference: the texel square clipped by the triangle's three edge half-planes (a different clip from the
// rasterizer's, which clips the triangle by the square), area by the shoelace formula.
double reference_coverage(Point2 a, Point2 b, Point2 c, int x, int y) {
  std::vector<Point2> poly{{double(x), double(y)}, {x + 1.0, double(y)}, {x + 1.0, y + 1.0}, {double(x), y + 1.0}};
  const double orient = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x) > 0 ? 1.0 : -1.0;
  const Point2 tri[3] = {a, b, c};
  for (int e = 0; e < 3; ++e) {
    const Point2 p = tri[e], q = tri[(e + 1) % 3];
    const auto side = [&](Point2 r) { return orient * ((q.x - p.x) * (r.y - p.y) - (q.y - p.y) * (r.x - p.x)); };
    std::vector<Point2> out;
    for (size_t i = 0; i < poly.size(); ++i) {
      const Point2 u = poly[i], v = poly[(i + 1) % poly.size()];
      const double su = side(u), sv = side(v);
      if (su >= 0) out.push_back(u);
      if ((su >= 0) != (sv >= 0)) {
        const double t = su / (su - sv);
        out.push_back({u.x + t * (v.x - u.x), u.y + t * (v.y - u.y)});
      }
    }
    poly = out;
    if (poly.empty()) return 0;
  }
  double twice = 0;
  for (size_t i = 0; i < poly.size(); ++i) {
    const Point2 u = poly[i], v = poly[(i + 1) % poly.size()];
    twice += u.x * v.y - u.y * v.x;
  }
  return 0.5 * std::fabs(twice);
}

// Coverage, and so which texels are valid, does not depend on the pattern: a tiled bake rasterizes the tiles it has
// no time left to sample with a 1×1 pattern for their validity alone.
TEST(Texels, RandomTrianglesMatchAnIndependentClipTexelByTexelWhateverThePattern) {
  Pcg32 rng(7);
  constexpr int kSize = 16;
  for (int trial = 0; trial < 600; ++trial) {
    // Both windings, some vertices outside the map (the part outside is not baked).
    std::vector<Point2> uv;
    for (int i = 0; i < 3; ++i) uv.push_back({rng.uniform() * 1.2 - 0.1, rng.uniform() * 1.2 - 0.1});
    const auto s = plane_scene(uv, {0, 1, 2});
    const int samples_per_axis = 1 << (trial % 3);  // 1, 2 and 4
    const LightmapTexels t = rasterize_lightmap(s, "plane", {kSize, kSize, samples_per_axis});
    const Point2 a{uv[0].x * kSize, uv[0].y * kSize}, b{uv[1].x * kSize, uv[1].y * kSize},
        c{uv[2].x * kSize, uv[2].y * kSize};
    const auto cov = coverage(t);
    for (int y = 0; y < kSize; ++y) {
      for (int x = 0; x < kSize; ++x) {
        const double expected = reference_coverage(a, b, c, x, y);
        if (expected > kMinCoverage) {
          ASSERT_TRUE(cov.count({x, y})) << "trial " << trial << " texel " << x << "," << y;
          // Both clips round on numbers up to 16 texels: ~10⁻¹⁴ at worst.
          EXPECT_NEAR(cov.at({x, y}), expected, kClipTol) << "trial " << trial;
        } else {
          EXPECT_FALSE(cov.count({x, y}) && cov.at({x, y}) > 2 * kMinCoverage) << "trial " << trial;
        }
      }
    }
  }
}

TEST(Texels, SliverThinnerThanATexelStillCoversTheTexelsItCrosses) {
  // From (0.5, 1.0) to (7.5, 1.0) and 0.02 texel tall at its right end: it runs through row 1 (y in [1, 1.02]) and
  // touches row 0 only along y = 1 (no area). No pattern point (y = 1.25, 1.75) is inside: one fallback point each.
  const double W = 8;
  const auto s = plane_scene({{0.5 / W, 1.0 / W}, {7.5 / W, 1.0 / W}, {7.5 / W, 1.02 / W}}, {0, 1, 2});
  const LightmapTexels t = rasterize_lightmap(s, "plane", {8, 8, 2});
  double total = 0;
  for (int x = 0; x < 8; ++x) {
    EXPECT_FALSE(t.valid(x, 0));
    ASSERT_TRUE(t.valid(x, 1)) << x;
    ASSERT_EQ(t.at(x, 1).size(), 1u) << x;
    const TexelSample& smp = t.at(x, 1)[0];
    EXPECT_TRUE(std::isfinite(smp.weight) && smp.weight > 0);
    EXPECT_TRUE(is_finite(smp.position));
    total += smp.weight;
  }
  // The weights add up to the triangle's texel-space area, ½ · 7 · 0.02.
  EXPECT_NEAR(total, 0.07, kClipTol);
}

TEST(Texels, DegenerateAndBrokenTrianglesProduceNothingAndAreReported) {
  // Collinear UVs (zero UV area) with a proper world triangle; a NaN UV; an index out of range.
  scene::Scene s = plane_scene({{0.1, 0.1}, {0.5, 0.5}, {0.9, 0.9}, {0.2, 0.8}}, {0, 1, 2, 0, 1, 9});
  s.meshes[0].positions = {{0, 0, 0}, {1, 0, 0}, {0, 0, 1}, {1, 0, 1}};
  s.meshes[0].lightmap_uv.push_back({std::nan(""), 0.5});
  s.meshes[0].positions.push_back({0, 1, 0});
  s.meshes[0].indices.insert(s.meshes[0].indices.end(), {0, 3, 4});
  const LightmapTexels t = rasterize_lightmap(s, "plane", {16, 16, 2});
  EXPECT_TRUE(t.samples.empty());
  EXPECT_EQ(t.valid_count(), 0u);
  EXPECT_EQ(t.report.skipped[static_cast<int>(SkipReason::degenerate_uv)], 1u);
  EXPECT_EQ(t.report.skipped[static_cast<int>(SkipReason::index_out_of_range)], 1u);
  EXPECT_EQ(t.report.skipped[static_cast<int>(SkipReason::non_finite_vertex)], 1u);
  ASSERT_EQ(t.report.skipped_examples.size(), 3u);
  EXPECT_EQ(t.report.skipped_examples[0].triangle.triangle, 0u);
  EXPECT_EQ(t.report.skipped_examples[1].triangle.triangle, 1u);
  EXPECT_EQ(t.report.skipped_examples[2].triangle.triangle, 2u);

  // Zero world area (all positions equal) with a proper UV triangle.
  scene::Scene z = plane_scene({{0.1, 0.1}, {0.9, 0.1}, {0.1, 0.9}}, {0, 1, 2});
  z.meshes[0].positions.assign(3, {1, 2, 3});
  const LightmapTexels tz = rasterize_lightmap(z, "plane", {16, 16, 2});
  EXPECT_TRUE(tz.samples.empty());
  EXPECT_EQ(tz.report.skipped[static_cast<int>(SkipReason::degenerate_world)], 1u);

  // A mesh without lightmap UVs bakes nothing; a missing mesh is reported.
  scene::Scene n = plane_scene({{0.1, 0.1}, {0.9, 0.1}, {0.1, 0.9}}, {0, 1, 2});
  n.meshes[0].lightmap_uv.clear();
  n.instances.push_back({});
  n.instances[1].mesh = 5;
  n.instances[1].lightmap = "plane";
  const LightmapTexels tn = rasterize_lightmap(n, "plane", {16, 16, 2});
  EXPECT_TRUE(tn.samples.empty());
  EXPECT_EQ(tn.report.skipped[static_cast<int>(SkipReason::no_lightmap_uv)], 1u);
  EXPECT_EQ(tn.report.skipped[static_cast<int>(SkipReason::no_mesh)], 1u);
}

TEST(Texels, BadVertexNormalsFallBackToTheGeometricNormal) {
  // Triangle 0: a NaN vertex normal; triangle 1: a zero one; triangle 2: normals that cancel at the centroid
  // (+y, −y and +y: 1/3 (n0 + n1 + n2) ≠ 0, but at b = (½, ½, 0) they cancel exactly).
  scene::Scene s = plane_scene({{0, 0}, {0, 1}, {1, 0}}, {0, 1, 2});
  s.meshes[0].positions = {{0, 0, 0}, {0, 0, 1}, {1, 0, 0}};  // front +y
  for (const Vec3 bad : {Vec3{std::nan(""), 1, 0}, Vec3{0, 0, 0}}) {
    s.meshes[0].normals = {{0, 1, 0}, bad, {0, 1, 0}};
    const LightmapTexels t = rasterize_lightmap(s, "plane", {8, 8, 2});
    ASSERT_FALSE(t.samples.empty());
    EXPECT_EQ(t.report.unusable_normals, 1u);
    for (const TexelSample& smp : t.samples) EXPECT_EQ(smp.shading_normal, (Vec3{0, 1, 0}));
  }
  s.meshes[0].normals = {{0, 1, 0}, {0, -1, 0}, {0, 1, 0}};
  const LightmapTexels t = rasterize_lightmap(s, "plane", {8, 8, 2});
  EXPECT_EQ(t.report.unusable_normals, 0u);
  for (const TexelSample& smp : t.samples) {
    EXPECT_TRUE(is_finite(smp.shading_normal));
    EXPECT_NEAR(length(smp.shading_normal), 1.0, 1e-12);  // unit, never a normalised zero
  }
}

TEST(Texels, UVsFarOutsideTheMapAreClippedWithoutHarm) {
  // One vertex at u = 10³⁰: the triangle is a huge sliver crossing the map; only its part inside is baked.
  const auto s = plane_scene({{0.5, 0.5}, {1e30, 0.5}, {0.5, 0.75}}, {0, 1, 2});
  const LightmapTexels t = rasterize_lightmap(s, "plane", {8, 8, 2});
  EXPECT_EQ(t.report.outside_unit_square, 1u);
  for (const TexelSample& smp : t.samples) {
    EXPECT_TRUE(is_finite(smp.position) && std::isfinite(smp.weight));
  }
  // In texel space it is (4, 4), (8·10³⁰, 4), (4, 6): over columns 4..7 its top edge is y = 6 to within 10⁻³⁰, so
  // it covers rows 4 and 5 of those columns whole (the clip's rounding is relative to the small coordinates).
  const auto cov = coverage(t);
  EXPECT_EQ(cov.size(), 8u);
  for (int y = 4; y <= 5; ++y) {
    for (int x = 4; x <= 7; ++x) EXPECT_NEAR(cov.at({x, y}), 1.0, kClipTol) << x << "," << y;
  }
}

TEST(Texels, BadOptionsAreRefusedWithTheFieldNamed) {
  const auto s = plane_scene({{0, 0}, {1, 0}, {0, 1}}, {0, 1, 2});
  try {
    rasterize_lightmap(s, "plane", {0, 4, 2});
    FAIL() << "width 0 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("width"), std::string::npos) << e.what();
  }
  EXPECT_THROW(rasterize_lightmap(s, "plane", {4, 4, 0}), std::invalid_argument);
  EXPECT_THROW(rasterize_lightmap(s, "plane", {4, 4, 17}), std::invalid_argument);
}

// A rotation about (1, 2, 3), a non-uniform scale (0.5, 2, 3) and a translation: p' = R S p + t.
scene::Transform skewed_transform(bool mirror) {
  const Vec3 axis = normalize(Vec3{1, 2, 3});
  const double angle = 0.7, c = std::cos(angle), s = std::sin(angle), C = 1 - c;
  const double x = axis.x, y = axis.y, z = axis.z;
  const double R[9] = {c + x * x * C,     x * y * C - z * s, x * z * C + y * s,  //
                       y * x * C + z * s, c + y * y * C,     y * z * C - x * s,  //
                       z * x * C - y * s, z * y * C + x * s, c + z * z * C};
  const double S[3] = {0.5, mirror ? -2.0 : 2.0, 3.0};
  scene::Transform t;
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) t.m[r * 4 + k] = R[r * 3 + k] * S[k];
  }
  t.m[3] = 10, t.m[7] = -4, t.m[11] = 2.5;
  return t;
}

// An (n × n)-quad grid chart over UV [lo, hi]², vertex (u, v) at position(u, v): 2n² triangles.
template <class Position>
scene::Scene grid_scene(const std::string& name, int n, double lo, double hi, Position position) {
  scene::Scene s;
  scene::Mesh m;
  m.name = name;
  for (int j = 0; j <= n; ++j) {
    for (int i = 0; i <= n; ++i) {
      const double u = lo + (hi - lo) * i / n, v = lo + (hi - lo) * j / n;
      m.positions.push_back(position(u, v));
      m.lightmap_uv.push_back({u, v});
    }
  }
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const uint32_t a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      m.indices.insert(m.indices.end(), {a, b, d, a, d, c});
    }
  }
  s.meshes.push_back(m);
  s.instances.push_back({});
  return s;
}

// The unit square of UV as a wavy 10 m patch.
scene::Scene wavy_grid(int n) {
  return grid_scene("grid", n, 0.0, 1.0, [](double u, double v) {
    return Vec3{u * 10, std::sin(20 * u) * std::cos(15 * v), v * 10};
  });
}

TEST(Texels, SamplesLieOnTheirTrianglesAndMapBackToTheirTexels) {
  // A curved (non-planar) 6×6-quad patch with a skewed instance transform.
  constexpr int N = 6;
  scene::Scene s = grid_scene("patch", N, 0.05, 0.95, [](double u, double v) {
    return Vec3{u, 0.3 * std::sin(3 * u) * std::cos(2 * v), v};
  });
  const scene::Mesh& m = s.meshes[0];
  s.instances[0].to_world = skewed_transform(false);
  const int W = 37, H = 23;  // not square, not a multiple of the grid
  const LightmapTexels t = rasterize_lightmap(s, "patch", {W, H, 3});
  ASSERT_GT(t.samples.size(), 0u);
  for (int y = 0; y < H; ++y) {
    for (int x = 0; x < W; ++x) {
      for (const TexelSample& smp : t.at(x, y)) {
        const double b1 = smp.barycentric.x, b2 = smp.barycentric.y, b0 = 1 - b1 - b2;
        // Barycentrics are clamped and renormalised: in [0, 1] up to the rounding of 1 − b1 − b2.
        ASSERT_GE(b0, -1e-12);
        ASSERT_GE(b1, 0.0);
        ASSERT_GE(b2, 0.0);
        ASSERT_LE(b1 + b2, 1.0 + 1e-12);
        const uint32_t* idx = &m.indices[3 * smp.triangle.triangle];
        // The UV of the point is in the texel: 1e-9 texels allows the rounding of barycentrics (~10⁻¹⁵) times
        // coordinates up to 37 texels, with room to spare; a wrong texel would be off by ≥ the pattern spacing.
        const Point2 uv0 = m.lightmap_uv[idx[0]], uv1 = m.lightmap_uv[idx[1]], uv2 = m.lightmap_uv[idx[2]];
        const double su = (b0 * uv0.x + b1 * uv1.x + b2 * uv2.x) * W;
        const double sv = (b0 * uv0.y + b1 * uv1.y + b2 * uv2.y) * H;
        EXPECT_GE(su, x - 1e-9);
        EXPECT_LE(su, x + 1 + 1e-9);
        EXPECT_GE(sv, y - 1e-9);
        EXPECT_LE(sv, y + 1 + 1e-9);
        // The world position is the same barycentric combination of the transformed vertices (scene size ~10:
        // 1e-12 relative is a few hundred ulps).
        const auto& T = s.instances[0].to_world;
        const Vec3 p =
            T.point(m.positions[idx[0]]) * b0 + T.point(m.positions[idx[1]]) * b1 + T.point(m.positions[idx[2]]) * b2;
        EXPECT_LT(length(p - smp.position), 1e-12 * 10);
        EXPECT_NEAR(length(smp.geometric_normal), 1.0, 1e-12);
        EXPECT_NEAR(length(smp.shading_normal), 1.0, 1e-12);
        EXPECT_GT(smp.weight, 0.0);
        EXPECT_GT(smp.texel_world_size, 0.0f);
        // The float tracer's lift: positive, and tiny next to a texel (its bound is ~1e-6 of the triangle's size).
        EXPECT_GT(smp.ray_offset, 0.0f);
        EXPECT_LT(smp.ray_offset, 1e-3f * smp.texel_world_size);
        EXPECT_EQ(smp.surface().offset, static_cast<double>(smp.ray_offset));
      }
    }
  }
}

TEST(Texels, NormalsFollowTheInverseTransposeAndMirroredInstancesKeepTheirFront) {
  // One triangle of the y = 0 plane whose front is +y (counter-clockwise seen from +y), with vertex normals +y.
  for (bool mirror : {false, true}) {
    scene::Scene s;
    scene::Mesh m;
    m.name = "tri";
    m.positions = {{0, 0, 0}, {0, 0, 1}, {1, 0, 0}};
    ASSERT_EQ(normalize(cross(m.positions[1] - m.positions[0], m.positions[2] - m.positions[0])), (Vec3{0, 1, 0}));
    m.normals.assign(3, {0, 1, 0});
    m.lightmap_uv = {{0, 0}, {0, 1}, {1, 0}};
    m.indices = {0, 1, 2};
    s.meshes.push_back(m);
    s.instances.push_back({});
    s.instances[0].to_world = skewed_transform(mirror);
    const LightmapTexels t = rasterize_lightmap(s, "tri", {8, 8, 1});
    ASSERT_FALSE(t.samples.empty());
    // The expected front normal: M^{-T} (0, 1, 0), the second row of M^{-1}, which is the cross product of the first
    // and third columns of M over det M.
    const auto& a = s.instances[0].to_world.m;
    const Vec3 c0{a[0], a[4], a[8]}, c1{a[1], a[5], a[9]}, c2{a[2], a[6], a[10]};
    const double det = dot(c0, cross(c1, c2));
    EXPECT_EQ(det < 0, mirror);
    const Vec3 expected = normalize(cross(c2, c0) / det);
    for (const TexelSample& smp : t.samples) {
      // A handful of operations on unit vectors: 1e-12 is generous and still catches any wrong sign or transform.
      EXPECT_LT(length(smp.geometric_normal - expected), 1e-12) << "mirror " << mirror;
      EXPECT_LT(length(smp.shading_normal - expected), 1e-12) << "mirror " << mirror;
    }
  }
}

TEST(Texels, InstancesShareAnAtlasThroughTheirScaleOffset) {
  // One unit-square chart baked by two instances into the left and right halves of one 16×8 atlas.
  scene::Scene s = plane_scene({{0, 0}, {1, 0}, {1, 1}, {0, 1}}, {0, 1, 2, 0, 2, 3});
  s.instances.resize(2);
  for (int i = 0; i < 2; ++i) {
    s.instances[i].lightmap = "atlas";
    s.instances[i].lightmap_scale_offset = {0.5, 1.0, 0.5 * i, 0.0};
  }
  EXPECT_EQ(lightmap_names(s), std::vector<std::string>{"atlas"});
  const LightmapTexels t = rasterize_lightmap(s, "atlas", {16, 8, 2});
  EXPECT_EQ(t.valid_count(), 128u);
  EXPECT_EQ(t.report.overlapping_texels, 0u);
  for (int y = 0; y < 8; ++y) {
    for (int x = 0; x < 16; ++x) {
      for (const TexelSample& smp : t.at(x, y)) EXPECT_EQ(smp.triangle.instance, x < 8 ? 0u : 1u);
    }
  }
  // A bake mask (scene check's "traced, not baked") leaves out the masked triangles: here the first of the two.
  const std::vector<std::vector<uint8_t>> mask{{0, 1}};
  RasterOptions masked{16, 8, 2};
  masked.bake_mask = &mask;
  const LightmapTexels half = rasterize_lightmap(s, "atlas", masked);
  EXPECT_EQ(half.report.masked, 2u);  // once per instance
  for (const TexelSample& smp : half.samples) EXPECT_EQ(smp.triangle.triangle, 1u);
  // Both in the same place: every texel is covered twice.
  s.instances[1].lightmap_scale_offset = s.instances[0].lightmap_scale_offset;
  const LightmapTexels o = rasterize_lightmap(s, "atlas", {16, 8, 2});
  EXPECT_EQ(o.report.overlapping_texels, 64u);
}

TEST(Texels, DeterministicWhateverTheThreads) {
  const scene::Scene s = wavy_grid(40);
  const LightmapTexels a = rasterize_lightmap(s, "grid", {64, 64, 2});
  const LightmapTexels b = rasterize_lightmap(s, "grid", {64, 64, 2});
  ASSERT_EQ(a.samples.size(), b.samples.size());
  EXPECT_EQ(a.first, b.first);
  EXPECT_EQ(0, std::memcmp(a.samples.data(), b.samples.data(), a.samples.size() * sizeof(TexelSample)));
}

// A tiled bake rasterizes each tile into the storage of the one before (rasterize_lightmap_into): every tile, from
// its bin, holds exactly the samples of the whole map's texels in its window, in the same order, to the byte,
// whether the storage was larger, smaller or fresh.
TEST(Texels, TilesRasterizedIntoOneStorageAreTheWindowsOfTheWholeMap) {
  const scene::Scene s = wavy_grid(40);
  const RasterOptions whole{64, 64, 2};
  const LightmapTexels map = rasterize_lightmap(s, "grid", whole);
  for (const int tile_size : {16, 40}) {
    const TileBins bins = bin_triangles(s, "grid", whole, tile_size);
    LightmapTexels storage;
    for (size_t k = 0; k < bins.tile_count(); ++k) {
      RasterOptions o = whole;
      o.window = bins.window(k);
      o.triangles = &bins.triangles[k];
      rasterize_lightmap_into(storage, s, "grid", o);
      ASSERT_EQ(storage.width, o.window.width);
      ASSERT_EQ(storage.height, o.window.height);
      for (int y = 0; y < storage.height; ++y) {
        for (int x = 0; x < storage.width; ++x) {
          const std::span<const TexelSample> a = storage.at(x, y), b = map.at(o.window.x0 + x, o.window.y0 + y);
          ASSERT_EQ(a.size(), b.size()) << "tile " << k << ", texel " << x << ", " << y;
          EXPECT_EQ(0, std::memcmp(a.data(), b.data(), a.size() * sizeof(TexelSample)));
        }
      }
    }
  }
}

// retain keeps the samples asked for, in order, and the texels left without any become invalid.
TEST(Texels, RetainKeepsTheSamplesAskedForInOrder) {
  const scene::Scene s = wavy_grid(40);
  const LightmapTexels map = rasterize_lightmap(s, "grid", {32, 32, 2});
  std::vector<uint8_t> keep(map.samples.size());
  // Every third sample and a run of them all, none of the first row's.
  for (size_t j = 0; j < keep.size(); ++j)
    keep[j] = j >= map.first[32] && (j % 3 == 0 || (j > keep.size() / 2 && j < keep.size() * 3 / 4));
  LightmapTexels kept = map;
  kept.retain(keep);
  size_t n = 0;
  for (size_t t = 0; t < map.texel_count(); ++t) {
    std::vector<TexelSample> expected;
    for (uint32_t j = map.first[t]; j < map.first[t + 1]; ++j)
      if (keep[j]) expected.push_back(map.samples[j]);
    const std::span<const TexelSample> got = kept.at(t);
    ASSERT_EQ(got.size(), expected.size()) << "texel " << t;
    for (size_t k = 0; k < got.size(); ++k) {
      EXPECT_EQ(got[k].position, expected[k].position) << "texel " << t;
      EXPECT_EQ(got[k].barycentric.x, expected[k].barycentric.x) << "texel " << t;
      EXPECT_EQ(got[k].barycentric.y, expected[k].barycentric.y) << "texel " << t;
      EXPECT_EQ(got[k].weight, expected[k].weight) << "texel " << t;
      EXPECT_EQ(got[k].triangle.instance, expected[k].triangle.instance) << "texel " << t;
      EXPECT_EQ(got[k].triangle.triangle, expected[k].triangle.triangle) << "texel " << t;
    }
    EXPECT_EQ(kept.valid(t), !expected.empty());
    n += expected.size();
  }
  EXPECT_EQ(kept.samples.size(), n);
  EXPECT_EQ(kept.valid_count(), map.valid_count() - 32);  // the first row lost every sample
}

TEST(Texels, HundredThousandTrianglesAt512Squared) {
  // 224² quads = 100 352 triangles tiling the unit square: every texel is covered exactly once in total.
  const scene::Scene s = wavy_grid(224);
  const auto start = std::chrono::steady_clock::now();
  const std::clock_t cpu_start = std::clock();
  const LightmapTexels t = rasterize_lightmap(s, "grid", {512, 512, 2});
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double cpu_seconds = static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;
  // Printed, not asserted (a shared machine's clock proves nothing): CPU time summed over threads, and wall time.
  std::printf("[ timing   ] rasterized %zu triangles into 512x512 texels (%zu samples): %.3f s wall, %.3f s CPU\n",
              t.report.triangles, t.samples.size(), seconds, cpu_seconds);
  std::printf("[ memory   ] %s\n", lightmap_memory(t).describe().c_str());
  EXPECT_EQ(t.report.triangles, 100352u);
  EXPECT_EQ(t.valid_count(), 512u * 512u);
  double worst = 0;
  for (size_t i = 0; i < t.texel_count(); ++i) {
    double sum = 0;
    for (const TexelSample& smp : t.at(i)) sum += smp.weight;
    worst = std::max(worst, std::fabs(sum - 1.0));
  }
  // Each texel's weights are the clipped areas of the ≤ ~8 triangles crossing it, each exact to ~10⁻¹⁵.
  EXPECT_LT(worst, kClipTol);
}

}  // namespace
}  // namespace kiln::lightmap
