// Seams (bakers/lightmap/seams.h): finding the world edges on two chart borders, and stitching the texels the
// bilinear lookups on both sides read so that they agree.
#include "bakers/lightmap/seams.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <set>
#include <utility>
#include <vector>

#include "bakers/lightmap/dilate.h"
#include "bakers/math/rgb.h"
#include "bakers/math/rng.h"
#include "tests/support/test_scenes.h"

namespace kiln::lightmap {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The face of add_box's cube a triangle belongs to: two triangles per face, in face order.
int face_of(const TriangleRef& t) { return static_cast<int>(t.triangle / 2); }

// The faces of add_box: +x, −x, +y, −y, +z, −z. Two faces meet at an edge unless they are opposite.
bool adjacent(int f, int g) { return f / 2 != g / 2; }

TEST(FindSeams, CubeUnwrappedIntoSixChartsHasTwelveSeamsEachOnce) {
  scene::Scene s;
  s.materials.push_back(test::lambert_material("white", 0.5));
  test::add_box(s, "cube", {-1, -1, -1}, {1, 1, 1}, 0);
  const SeamSearch found = find_seams(s, "cube", 64, 64);
  ASSERT_EQ(found.seams.size(), 12u);
  EXPECT_EQ(found.edges, 18u);  // 12 cube edges and one diagonal per face
  EXPECT_EQ(found.shared_edges, 18u);
  EXPECT_EQ(found.non_manifold + found.degenerate + found.outside + found.skipped_triangles, 0u);
  std::set<std::pair<int, int>> pairs;
  for (const Seam& seam : found.seams) {
    const int f = face_of(seam.a), g = face_of(seam.b);
    ASSERT_NE(f, g);
    EXPECT_TRUE(adjacent(f, g)) << f << " " << g;
    pairs.insert({std::min(f, g), std::max(f, g)});
  }
  EXPECT_EQ(pairs.size(), 12u);  // every pair of adjacent faces once: each cube edge is one seam
}

TEST(FindSeams, SeamEndsMeetInWorldSpace) {
  // a0/b0 and a1/b1 are the same world point: in add_box's layout every chart is axis-aligned and its edge's ends
  // are a chart's corners; both sides' lengths equal the face's side in texels (the cube's faces are squares, so the
  // lengths are a chart's width or height).
  scene::Scene s;
  s.materials.push_back(test::lambert_material("white", 0.5));
  test::add_box(s, "cube", {-1, -1, -1}, {1, 1, 1}, 0);
  const SeamSearch found = find_seams(s, "cube", 48, 48);
  for (const Seam& seam : found.seams) {
    const double la = std::hypot(seam.a1.x - seam.a0.x, seam.a1.y - seam.a0.y);
    const double lb = std::hypot(seam.b1.x - seam.b0.x, seam.b1.y - seam.b0.y);
    EXPECT_GT(la, 1.0);
    EXPECT_GT(lb, 1.0);
  }
}

// A cube of 8 welded vertices (and the same with every face's vertices split, positions repeated) whose UVs are one
// per position: every shared edge has the same UVs on both sides, so there is no seam.
TEST(FindSeams, ClosedMeshWithContinuousUvsHasNone) {
  for (const bool split : {false, true}) {
    scene::Scene s;
    s.materials.push_back(test::lambert_material("white", 0.5));
    scene::Mesh m;
    m.name = "cube";
    std::vector<Vec3> corners;
    std::vector<Point2> corner_uv;
    for (int i = 0; i < 8; ++i) {
      corners.push_back({(i & 1) ? 1.0 : -1.0, (i & 2) ? 1.0 : -1.0, (i & 4) ? 1.0 : -1.0});
      corner_uv.push_back({0.1 + 0.1 * i, 0.9 - 0.05 * i});  // distinct, inside the page
    }
    const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (const auto& q : quads) {
      for (const int tri : {0, 1}) {
        const int ids[3] = {q[0], q[tri + 1], q[tri + 2]};
        for (const int id : ids) {
          if (split) {
            m.indices.push_back(static_cast<uint32_t>(m.positions.size()));
            m.positions.push_back(corners[id]);
            m.lightmap_uv.push_back(corner_uv[id]);
          } else {
            m.indices.push_back(static_cast<uint32_t>(id));
          }
        }
      }
    }
    if (!split) {
      m.positions = corners;
      m.lightmap_uv = corner_uv;
    }
    s.meshes.push_back(m);
    s.instances.push_back({});
    const SeamSearch found = find_seams(s, "cube", 64, 64);
    EXPECT_EQ(found.seams.size(), 0u) << "split " << split;
    EXPECT_EQ(found.edges, 18u);
    EXPECT_EQ(found.shared_edges, 18u);
  }
}

// Two instances of one quad side by side in world space, in one lightmap at different scale-offsets: their shared
// edge is one seam. Apart in world space, or in different lightmaps, none.
TEST(FindSeams, InstancesSharingAPageMeetOnlyWhereTheyShareAnEdge) {
  for (const double gap : {0.0, 1e-9, 0.5}) {
    scene::Scene s;
    s.materials.push_back(test::lambert_material("white", 0.5));
    test::add_quad(s, "quad", {0, 0, 0}, {1, 0, 0}, {1, 0, -1}, {0, 0, -1}, 0);
    scene::Instance second = s.instances[0];
    second.to_world.m[3] = 1 + gap;  // translated along +x
    s.instances.push_back(second);
    s.instances[0].lightmap = s.instances[1].lightmap = "page";
    s.instances[0].lightmap_scale_offset = {0.4, 0.4, 0.05, 0.05};
    s.instances[1].lightmap_scale_offset = {0.4, 0.4, 0.55, 0.05};
    const SeamSearch found = find_seams(s, "page", 32, 32);
    // 1e-9 m apart is within the weld (10⁻⁶ of the 2 m extent): the same edge, exported with rounding.
    EXPECT_EQ(found.seams.size(), gap < 1e-6 ? 1u : 0u) << "gap " << gap;
    if (found.seams.size() == 1) {
      const Seam& seam = found.seams[0];
      EXPECT_NE(seam.a.instance, seam.b.instance);
      // The first instance's right edge (u = 1 → 0.45·32 = 14.4) against the second's left edge (u = 0 → 17.6).
      EXPECT_NEAR(seam.a0.x, 14.4, 1e-9);
      EXPECT_NEAR(seam.b0.x, 17.6, 1e-9);
    }
    s.instances[1].lightmap = "other";
    EXPECT_EQ(find_seams(s, "page", 32, 32).seams.size(), 0u);
  }
}

TEST(FindSeams, BadGeometryIsCountedNeverFatal) {
  scene::Scene s;
  s.materials.push_back(test::lambert_material("white", 0.5));
  test::add_box(s, "cube", {-1, -1, -1}, {1, 1, 1}, 0);
  scene::Mesh& m = s.meshes[0];
  m.lightmap_uv[0] = {kNaN, 0.5};                          // a NaN UV: its triangles are left out
  m.positions[5] = {kNaN, 0, 0};                           // a NaN position too
  m.indices.push_back(999);                                // a trailing index: no whole triangle
  for (int k = 8; k < 12; ++k) m.lightmap_uv[k] = {0.5, 0.5};  // one face collapsed to a point in UV
  for (int k = 12; k < 16; ++k) m.lightmap_uv[k].x += 2;   // one face outside the page
  SeamSearch found;
  EXPECT_NO_THROW(found = find_seams(s, "cube", 64, 64));
  EXPECT_GT(found.skipped_triangles, 0u);
  EXPECT_GT(found.degenerate, 0u);
  EXPECT_GT(found.outside, 0u);
  EXPECT_LT(found.seams.size(), 12u);
  for (const Seam& seam : found.seams) {
    for (const Point2& p : {seam.a0, seam.a1, seam.b0, seam.b1}) {
      EXPECT_TRUE(std::isfinite(p.x) && std::isfinite(p.y));
    }
  }
  EXPECT_EQ(find_seams(s, "no such lightmap", 64, 64).seams.size(), 0u);
  EXPECT_THROW(find_seams(s, "cube", 0, 64), std::invalid_argument);
}

// ---- The solver on a synthetic image ----

// Two charts of a 40 × 20 lightmap: A covers columns [4, 14), B columns [24, 34), rows [3, 17) both. A's right
// border (s = 14) and B's left border (s = 24) are one world edge, run in the same direction (t from 3 to 17). A
// holds 1 + 0.02·y, B 1.5 + 0.03·y plus noise: a step across the seam. Dilated by 2 texels as the bake does.
struct TwoCharts {
  int width = 40, height = 20;
  std::vector<uint8_t> valid;
  image::FloatImage image;
  std::vector<Seam> seams;

  explicit TwoCharts(int channels = 3) {
    valid.assign(static_cast<size_t>(width) * height, 0);
    image.width = width;
    image.height = height;
    image.channels = channels;
    image.pixels.assign(valid.size() * channels, 0.0f);
    Pcg32 rng(7);
    for (int y = 3; y < 17; ++y) {
      for (int x = 0; x < width; ++x) {
        const bool a = x >= 4 && x < 14, b = x >= 24 && x < 34;
        if (!a && !b) continue;
        const size_t t = static_cast<size_t>(y) * width + x;
        valid[t] = 1;
        for (int c = 0; c < channels; ++c) {
          const double v = a ? 1 + 0.02 * y + 0.1 * c : 1.5 + 0.03 * y + 0.05 * rng.uniform();
          image.pixels[t * channels + c] = static_cast<float>(v);
        }
      }
    }
    dilate(image, valid, 2);
    Seam s;
    s.a0 = {14, 3};
    s.a1 = {14, 17};
    s.b0 = {24, 3};
    s.b1 = {24, 17};
    seams.push_back(s);
  }
};

// Bilinear lookup as seams.h defines it (clamp to edge), for the test's own check.
double lookup(const image::FloatImage& img, Point2 p, int c) {
  const double x = p.x - 0.5, y = p.y - 0.5;
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const double fx = x - x0, fy = y - y0;
  const auto at = [&](int xi, int yi) {
    xi = std::clamp(xi, 0, img.width - 1);
    yi = std::clamp(yi, 0, img.height - 1);
    return static_cast<double>(img.pixels[(static_cast<size_t>(yi) * img.width + xi) * img.channels + c]);
  };
  return (1 - fx) * (1 - fy) * at(x0, y0) + fx * (1 - fy) * at(x0 + 1, y0) + (1 - fx) * fy * at(x0, y0 + 1) +
         fx * fy * at(x0 + 1, y0 + 1);
}

// The largest |lookup A − lookup B| along the seams at `n` points each (finer than the stitcher's own).
double largest_mismatch(const image::FloatImage& img, const std::vector<Seam>& seams, int n = 257) {
  double worst = 0;
  for (const Seam& s : seams) {
    for (int k = 0; k <= n; ++k) {
      const double t = static_cast<double>(k) / n;
      const Point2 a{s.a0.x + t * (s.a1.x - s.a0.x), s.a0.y + t * (s.a1.y - s.a0.y)};
      const Point2 b{s.b0.x + t * (s.b1.x - s.b0.x), s.b0.y + t * (s.b1.y - s.b0.y)};
      for (int c = 0; c < img.channels; ++c) worst = std::max(worst, std::abs(lookup(img, a, c) - lookup(img, b, c)));
    }
  }
  return worst;
}

TEST(SeamStitcher, MakesTheLookupsOnBothSidesAgree) {
  TwoCharts charts;
  const image::FloatImage before = charts.image;
  const SeamStitcher stitcher(charts.seams, charts.width, charts.height, charts.valid);
  const StitchStats stats = stitcher.stitch(charts.image);
  EXPECT_TRUE(stats.converged);
  EXPECT_EQ(stats.channels_skipped, 0u);
  EXPECT_EQ(stats.samples, 29u);  // 14 texels long: 28 half-texel segments, ends included
  const double step = largest_mismatch(before, charts.seams);
  EXPECT_GT(step, 0.4);
  // The least-squares fit leaves a residual of about c/(w_seam Σ α²/c) of the step: the seam weight (100) against
  // the dilated texels' confidence (0.01), which give way first. 10⁻³ of the step bounds it with room; measured
  // here between the stitcher's points too, where the lookups are linear interpolations of its own.
  const double after = largest_mismatch(charts.image, charts.seams);
  std::printf("two charts: mismatch %.3g -> %.3g (%zu unknowns, %zu texels changed, %d CG iterations)\n", step, after,
              stats.unknowns, stats.texels_changed, stats.iterations);
  EXPECT_LT(after, 1e-3 * step) << "before " << step << " after " << after;
  EXPECT_LT(stats.mismatch_after, 1e-3 * stats.mismatch_before);
  EXPECT_GT(stats.texels_changed, 0u);
  EXPECT_LE(stats.texels_changed, stats.unknowns);
  // Texels no lookup reads keep their bytes: only columns 12–15 and 22–25 (the two texels either side of each
  // border) can change.
  size_t unchanged = 0;
  for (int y = 0; y < charts.height; ++y) {
    for (int x = 0; x < charts.width; ++x) {
      const bool read = (x >= 12 && x <= 15) || (x >= 22 && x <= 25);
      const size_t t = (static_cast<size_t>(y) * charts.width + x) * 3;
      if (read) continue;
      EXPECT_EQ(std::memcmp(&charts.image.pixels[t], &before.pixels[t], 3 * sizeof(float)), 0) << x << "," << y;
      ++unchanged;
    }
  }
  EXPECT_EQ(unchanged, static_cast<size_t>(charts.width - 8) * charts.height);
  // Valid texels move less than dilated ones (their confidence is 100 times higher).
  double valid_move = 0, dilated_move = 0;
  for (size_t t = 0; t < charts.valid.size(); ++t) {
    const double d = std::abs(charts.image.pixels[3 * t] - before.pixels[3 * t]);
    (charts.valid[t] ? valid_move : dilated_move) = std::max(charts.valid[t] ? valid_move : dilated_move, d);
  }
  EXPECT_LT(valid_move, dilated_move);
}

TEST(SeamStitcher, IsDeterministicAndLeavesAgreeingSeamsAlone) {
  TwoCharts a, b;
  const SeamStitcher stitcher(a.seams, a.width, a.height, a.valid);
  stitcher.stitch(a.image);
  stitcher.stitch(b.image);
  EXPECT_EQ(a.image.pixels, b.image.pixels);
  // A constant image: the lookups agree exactly, nothing changes.
  TwoCharts flat;
  std::fill(flat.image.pixels.begin(), flat.image.pixels.end(), 2.5f);
  const std::vector<float> before = flat.image.pixels;
  const StitchStats stats = stitcher.stitch(flat.image);
  EXPECT_EQ(stats.texels_changed, 0u);
  EXPECT_EQ(stats.mismatch_before, 0.0);
  EXPECT_EQ(flat.image.pixels, before);
}

TEST(SeamStitcher, OneChannelImages) {
  TwoCharts charts(1);
  const double step = largest_mismatch(charts.image, charts.seams);
  const StitchStats stats = SeamStitcher(charts.seams, charts.width, charts.height, charts.valid).stitch(charts.image);
  EXPECT_LT(largest_mismatch(charts.image, charts.seams), 1e-3 * step);
  EXPECT_GT(stats.texels_changed, 0u);
}

TEST(SeamStitcher, DegenerateSeamsAndValuesNeverCrash) {
  TwoCharts charts;
  std::vector<Seam> seams = charts.seams;
  Seam nan_seam = seams[0];
  nan_seam.a1 = {kNaN, 3};
  Seam point = seams[0];
  point.a1 = point.a0;  // no length on side A
  Seam outside = seams[0];
  outside.b1 = {24, 25};  // below the 20-row page
  Seam infinite = seams[0];
  infinite.b0 = {std::numeric_limits<double>::infinity(), 0};
  seams.insert(seams.end(), {nan_seam, point, outside, infinite});
  const SeamStitcher stitcher(seams, charts.width, charts.height, charts.valid);
  EXPECT_EQ(stitcher.seams_used(), 1u);
  // A NaN in a texel the lookups read: that channel is left alone, nothing NaN spreads.
  image::FloatImage img = charts.image;
  img.pixels[(static_cast<size_t>(8) * charts.width + 13) * 3 + 1] = std::numeric_limits<float>::quiet_NaN();
  const StitchStats stats = stitcher.stitch(img);
  EXPECT_EQ(stats.channels_skipped, 1u);
  size_t nans = 0;
  for (const float v : img.pixels) nans += std::isnan(v) ? 1 : 0;
  EXPECT_EQ(nans, 1u);
  // No seams at all, and bad sizes.
  image::FloatImage untouched = charts.image;
  EXPECT_EQ(SeamStitcher({}, charts.width, charts.height, charts.valid).stitch(untouched).texels_changed, 0u);
  EXPECT_EQ(untouched.pixels, charts.image.pixels);
  EXPECT_THROW(SeamStitcher(charts.seams, charts.width, charts.height + 1, charts.valid), std::invalid_argument);
  StitchOptions bad;
  bad.dilated_weight = 0;
  EXPECT_THROW(SeamStitcher(charts.seams, charts.width, charts.height, charts.valid, bad), std::invalid_argument);
  image::FloatImage wrong = charts.image;
  wrong.width = 10;
  EXPECT_THROW(stitcher.stitch(wrong), std::invalid_argument);
}

}  // namespace
}  // namespace kiln::lightmap
