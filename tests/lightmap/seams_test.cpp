// Seams (bakers/lightmap/seams.h): finding the world edges on two chart borders, and stitching the texels the
// bilinear lookups on both sides read so that they agree.
#include "bakers/lightmap/seams.h"
#include "bakers/lightmap/lightmap_results.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <set>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>
#include <tbb/global_control.h>

#include "bakers/lightmap/dilate.h"
#include "bakers/lightmap/lightmap_bake.h"
#include "bakers/math/constants.h"
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
  SeamStitcher stitcher(charts.seams, charts.width, charts.height, charts.valid);
  const StitchStats stats = stitcher.stitch(charts.image);
  EXPECT_TRUE(stats.converged);
  EXPECT_EQ(stats.channels_skipped, 0u);
  EXPECT_EQ(stats.samples, 29u);  // 14 texels long: 28 half-texel segments, ends included
  const double step = largest_mismatch(before, charts.seams);
  EXPECT_GT(step, 0.4);
  // The least-squares fit leaves a residual of about c/(w_seam Σα²) of the step, the seam weight (1000) against the
  // confidence of the texels that give way (0.01 for the dilated ones, which do here): about 2·10⁻⁵ (measured). 10⁻³
  // of the step bounds it with room; measured here between the stitcher's points too (8 a texel).
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
  SeamStitcher stitcher(a.seams, a.width, a.height, a.valid);
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

// Two systems that share no texel (charts of different instances on one page) are solved apart: stitched together,
// each half gets the bytes it gets stitched alone, whatever the number of threads.
TEST(SeamStitcher, IndependentSeamsAreSolvedApartWithTheSameBytes) {
  TwoCharts top, bottom_alone;
  for (float& v : bottom_alone.image.pixels) v = 3 * v + 0.25f;  // another lightmap's values
  image::FloatImage page;
  page.width = top.width;
  page.height = 2 * top.height;
  page.channels = 3;
  page.pixels = top.image.pixels;
  page.pixels.insert(page.pixels.end(), bottom_alone.image.pixels.begin(), bottom_alone.image.pixels.end());
  std::vector<uint8_t> valid = top.valid;
  valid.insert(valid.end(), bottom_alone.valid.begin(), bottom_alone.valid.end());
  std::vector<Seam> seams = top.seams;
  Seam lower = top.seams[0];
  for (Point2* p : {&lower.a0, &lower.a1, &lower.b0, &lower.b1}) p->y += top.height;
  seams.push_back(lower);

  SeamStitcher both(seams, page.width, page.height, valid);
  EXPECT_EQ(both.components(), 2u);
  SeamStitcher alone(top.seams, top.width, top.height, top.valid);
  EXPECT_EQ(alone.components(), 1u);
  image::FloatImage one_thread = page;
  {
    const tbb::global_control serial(tbb::global_control::max_allowed_parallelism, 1);
    both.stitch(one_thread);
  }
  const StitchStats stats = both.stitch(page);
  EXPECT_TRUE(stats.converged);
  EXPECT_EQ(page.pixels, one_thread.pixels);
  alone.stitch(top.image);
  alone.stitch(bottom_alone.image);
  const size_t half = top.image.pixels.size();
  EXPECT_TRUE(std::equal(top.image.pixels.begin(), top.image.pixels.end(), page.pixels.begin()));
  EXPECT_TRUE(std::equal(bottom_alone.image.pixels.begin(), bottom_alone.image.pixels.end(), page.pixels.begin() + half));
}

// An image whose lookups all agree (a page left black by a time limit) needs no system: none is built, nothing changes.
// The first image with a mismatch builds and factors it.
TEST(SeamStitcher, ImagesWhoseLookupsAgreeBuildNoSystem) {
  TwoCharts black, lit;
  std::fill(black.image.pixels.begin(), black.image.pixels.end(), 0.0f);
  SeamStitcher stitcher(black.seams, black.width, black.height, black.valid);
  const StitchStats none = stitcher.stitch(black.image);
  EXPECT_EQ(none.texels_changed, 0u);
  EXPECT_EQ(none.components, 1u);
  EXPECT_EQ(none.factored, 0u);
  EXPECT_EQ(stitcher.factored_components(), 0u);
  for (const float v : black.image.pixels) ASSERT_EQ(v, 0.0f);
  const StitchStats some = stitcher.stitch(lit.image);
  EXPECT_GT(some.texels_changed, 0u);
  EXPECT_EQ(some.factored, 1u);
}

// Each component is solved by its Cholesky factor unless its budget is 0; conjugate gradients run to their tolerance
// then reach the same answer. CG stops at a relative residual of 10⁻¹⁰ (default), so its change d is within κ · 10⁻¹⁰
// of the exact one, κ ≤ 10⁵ here (the seam weight over the dilated texels'): 10⁻⁵ of the largest change; the images
// are float (2⁻²⁴ relative). 10⁻⁴ of the largest change plus 10⁻⁶ of the value bounds both with room.
TEST(SeamStitcher, FactoredAndConjugateGradientSolutionsAgree) {
  TwoCharts direct, iterative;
  const image::FloatImage before = direct.image;
  SeamStitcher factored(direct.seams, direct.width, direct.height, direct.valid);
  StitchOptions cg_only;
  cg_only.factor_budget = 0;
  SeamStitcher by_cg(iterative.seams, iterative.width, iterative.height, iterative.valid, cg_only);
  const StitchStats a = factored.stitch(direct.image);
  const StitchStats b = by_cg.stitch(iterative.image);
  EXPECT_EQ(a.components, 1u);
  EXPECT_EQ(a.factored, 1u);
  EXPECT_EQ(a.iterations, 0);
  EXPECT_EQ(b.factored, 0u);
  EXPECT_GT(b.iterations, 0);
  EXPECT_TRUE(a.converged && b.converged);
  double largest_change = 0;
  for (size_t i = 0; i < before.pixels.size(); ++i) {
    largest_change = std::max(largest_change, std::abs(static_cast<double>(direct.image.pixels[i]) - before.pixels[i]));
  }
  ASSERT_GT(largest_change, 0.1);
  for (size_t i = 0; i < before.pixels.size(); ++i) {
    EXPECT_NEAR(direct.image.pixels[i], iterative.image.pixels[i],
                1e-4 * largest_change + 1e-6 * std::abs(direct.image.pixels[i]))
        << "value " << i;
  }
}

// Two lightmaps' worth of seams on one page, one component each (as in IndependentSeamsAreSolvedApart...).
struct TwoComponentPage {
  image::FloatImage image;
  std::vector<uint8_t> valid;
  std::vector<Seam> seams;
  TwoComponentPage() {
    TwoCharts top, bottom;
    for (float& v : bottom.image.pixels) v = 3 * v + 0.25f;
    image = top.image;
    image.height = 2 * top.height;
    image.pixels.insert(image.pixels.end(), bottom.image.pixels.begin(), bottom.image.pixels.end());
    valid = top.valid;
    valid.insert(valid.end(), bottom.valid.begin(), bottom.valid.end());
    seams = top.seams;
    Seam lower = top.seams[0];
    for (Point2* p : {&lower.a0, &lower.a1, &lower.b0, &lower.b1}) p->y += top.height;
    seams.push_back(lower);
  }
};

// The factors kept, with what factoring them holds (each component's matrix and working space), stay within the byte
// cap: components are factored in order while they fit, the rest solved by CG from the lookups, to the same values
// (CG's tolerance, as in FactoredAndConjugateGradientSolutionsAgree).
TEST(SeamStitcher, FactorsBeyondTheByteCapAreSolvedByConjugateGradients) {
  const TwoComponentPage page;
  const auto stitched = [&](size_t cap, image::FloatImage& out) {
    StitchOptions options;
    options.factor_bytes_per_texel = 0;
    options.min_factor_bytes = cap;
    SeamStitcher stitcher(page.seams, page.image.width, page.image.height, page.valid, options);
    out = page.image;
    const StitchStats s = stitcher.stitch(out);
    EXPECT_TRUE(s.converged);
    EXPECT_LE(stitcher.factor_bytes(), cap);
    return std::make_pair(s, stitcher.factor_bytes());
  };
  image::FloatImage all, one, none;
  const auto [all_stats, both_bytes] = stitched(size_t{1} << 30, all);
  ASSERT_EQ(all_stats.factored, 2u);
  // The least cap that factors one component: more than its factor alone, less than both factors with their
  // factoring.
  size_t lo = 0, hi = size_t{1} << 30;  // factors none at lo, at least one at hi
  while (hi - lo > 1) {
    const size_t mid = lo + (hi - lo) / 2;
    image::FloatImage scratch;
    (stitched(mid, scratch).first.factored > 0 ? hi : lo) = mid;
  }
  const auto [one_stats, one_bytes] = stitched(hi, one);
  EXPECT_EQ(one_stats.factored, 1u);
  // The two components are the same seam shifted: their factors hold the same bytes.
  EXPECT_EQ(one_bytes, both_bytes / 2);
  EXPECT_GT(hi, one_bytes);
  EXPECT_GT(one_stats.iterations, 0);
  const auto [none_stats, no_bytes] = stitched(hi - 1, none);
  EXPECT_EQ(none_stats.factored, 0u);
  EXPECT_EQ(no_bytes, 0u);
  double largest_change = 0;
  for (size_t i = 0; i < all.pixels.size(); ++i) {
    largest_change = std::max(largest_change, std::abs(static_cast<double>(all.pixels[i]) - page.image.pixels[i]));
  }
  ASSERT_GT(largest_change, 0.1);
  for (size_t i = 0; i < all.pixels.size(); ++i) {
    const double tolerance = 1e-4 * largest_change + 1e-6 * std::abs(all.pixels[i]);
    ASSERT_NEAR(one.pixels[i], all.pixels[i], tolerance) << "value " << i;
    ASSERT_NEAR(none.pixels[i], all.pixels[i], tolerance) << "value " << i;
  }
  // The first component, factored under either cap, gives the same bytes.
  const size_t half = all.pixels.size() / 2;
  EXPECT_TRUE(std::equal(one.pixels.begin(), one.pixels.begin() + half, all.pixels.begin()));
}

// The lookups stay within their byte budget: seams are taken in order while their points (kLookupPointBytes each, a
// point every half texel, ends included) fit; the rest are counted and not stitched.
TEST(SeamStitcher, SeamsBeyondTheLookupBudgetAreCountedAndLeftOut) {
  const TwoComponentPage page;
  const size_t texels = page.valid.size();
  const size_t one_seam = (2 * 14 + 1) * kLookupPointBytes;  // 14 texels long: 29 points
  StitchOptions options;
  options.min_lookup_bytes = 0;
  options.lookup_bytes_per_texel = static_cast<double>(one_seam) / static_cast<double>(texels);
  SeamStitcher first_only(page.seams, page.image.width, page.image.height, page.valid, options);
  EXPECT_EQ(first_only.seams_used(), 1u);
  EXPECT_EQ(first_only.seams_over_budget(), 1u);
  EXPECT_EQ(first_only.samples(), 29u);
  EXPECT_EQ(first_only.components(), 1u);
  options.lookup_bytes_per_texel = static_cast<double>(one_seam - 1) / static_cast<double>(texels);
  SeamStitcher none(page.seams, page.image.width, page.image.height, page.valid, options);
  EXPECT_EQ(none.seams_used(), 0u);
  EXPECT_EQ(none.seams_over_budget(), 2u);
  image::FloatImage untouched = page.image;
  EXPECT_EQ(none.stitch(untouched).texels_changed, 0u);
  EXPECT_EQ(untouched.pixels, page.image.pixels);
  // The stitched seam is the first, as with no budget; the second keeps its bytes.
  image::FloatImage capped = page.image, full = page.image;
  first_only.stitch(capped);
  SeamStitcher(page.seams, page.image.width, page.image.height, page.valid).stitch(full);
  const size_t half = full.pixels.size() / 2;
  EXPECT_TRUE(std::equal(capped.pixels.begin(), capped.pixels.begin() + half, full.pixels.begin()));
  EXPECT_TRUE(std::equal(capped.pixels.begin() + half, capped.pixels.end(), page.image.pixels.begin() + half));
  options.lookup_bytes_per_texel = -1;
  EXPECT_THROW(SeamStitcher(page.seams, page.image.width, page.image.height, page.valid, options),
               std::invalid_argument);
}

// The peak counts at least what the stitcher cannot do without: the validity map (a byte a texel), each lookup pair
// (8 bytes) with its taps (at least one per side, 8 bytes each), each unknown's texel (4); then, once it stitches,
// per unknown the image's values and the right-hand side and solution (3 doubles), and either CG's diagonal and four
// vectors (5 doubles), or the factor's diagonal (8).
TEST(SeamStitcher, PeakBytesCountWhatTheStitcherMustHold) {
  TwoCharts direct, iterative;
  StitchOptions cg_only;
  cg_only.factor_budget = 0;
  SeamStitcher factored(direct.seams, direct.width, direct.height, direct.valid);
  SeamStitcher by_cg(iterative.seams, iterative.width, iterative.height, iterative.valid, cg_only);
  const size_t n = factored.unknowns();
  const size_t lookups = direct.valid.size() + factored.samples() * (8 + 2 * 8) + n * 4;
  EXPECT_GE(factored.peak_bytes(), lookups);
  const size_t built = factored.peak_bytes();
  factored.stitch(direct.image);
  by_cg.stitch(iterative.image);
  EXPECT_GE(factored.peak_bytes(), std::max(built, lookups + n * (3 + 1) * 8));
  EXPECT_GE(by_cg.peak_bytes(), lookups + n * (3 + 5) * 8);
}

// A page of nothing but seams: `count` short seams (half a texel to two texels long) at random places, the other
// side's start either anywhere (so that the seams join into one component) or within the same 8 × 8-texel tile (many
// small components). Random values, a fifth of them 0, so that fits go below 0 and values are held there.
struct SeamsEverywhere {
  int size;
  std::vector<uint8_t> valid;
  image::FloatImage image;
  std::vector<Seam> seams;

  SeamsEverywhere(int size_, size_t count, bool in_tiles) : size(size_) {
    Pcg32 rng(in_tiles ? 11 : 12);
    valid.assign(static_cast<size_t>(size) * size, 0);
    image.width = image.height = size;
    image.channels = 3;
    image.pixels.resize(valid.size() * 3);
    for (size_t t = 0; t < valid.size(); ++t) {
      valid[t] = rng.uniform() < 0.7;
      for (int c = 0; c < 3; ++c) image.pixels[t * 3 + c] = rng.uniform() < 0.2 ? 0.0f : 10 * rng.uniform();
    }
    const auto inside = [&](double v) { return std::clamp(v, 0.0, static_cast<double>(size)); };
    const auto along = [&](Point2 p) {
      const double angle = 2 * kPi * rng.uniform(), length = 0.5 + 1.5 * rng.uniform();
      return Point2{inside(p.x + length * std::cos(angle)), inside(p.y + length * std::sin(angle))};
    };
    for (size_t k = 0; k < count; ++k) {
      Seam s;
      s.a0 = {size * rng.uniform(), size * rng.uniform()};
      s.a1 = along(s.a0);
      if (in_tiles) {
        s.b0 = {std::floor(s.a0.x / 8) * 8 + 1 + 6 * rng.uniform(), std::floor(s.a0.y / 8) * 8 + 1 + 6 * rng.uniform()};
        s.a0 = {std::floor(s.a0.x / 8) * 8 + 1 + 6 * rng.uniform(), std::floor(s.a0.y / 8) * 8 + 1 + 6 * rng.uniform()};
        s.a1 = {std::clamp(s.a1.x, std::floor(s.a0.x / 8) * 8 + 1, std::floor(s.a0.x / 8) * 8 + 7),
                std::clamp(s.a1.y, std::floor(s.a0.y / 8) * 8 + 1, std::floor(s.a0.y / 8) * 8 + 7)};
      } else {
        s.b0 = {size * rng.uniform(), size * rng.uniform()};
      }
      s.b1 = along(s.b0);
      if (in_tiles) {
        s.b1 = {std::clamp(s.b1.x, std::floor(s.b0.x / 8) * 8 + 1, std::floor(s.b0.x / 8) * 8 + 7),
                std::clamp(s.b1.y, std::floor(s.b0.y / 8) * 8 + 1, std::floor(s.b0.y / 8) * 8 + 7)};
      }
      seams.push_back(s);
    }
  }
};

// Whatever the seams, the stitcher holds no more than SeamStitcher::bytes_bound: pages whose every texel is read by
// some lookup, with more seams than the lookup budget takes, solved by CG as one component or factored as many (the
// factor cap reached or not), with values held at 0. The memory is the point, not the fit: CG stops at 50 iterations.
TEST(SeamStitcher, HoldsNoMoreThanItsBoundWhateverTheSeams) {
  constexpr int kSize = 64;
  constexpr size_t kTexels = kSize * kSize;
  for (const bool in_tiles : {false, true}) {
    for (const double factor_bytes : {80.0, 8.0}) {
      SeamsEverywhere page(kSize, kTexels / 2, in_tiles);
      StitchOptions options;
      options.min_factor_bytes = options.min_lookup_bytes = 0;
      options.factor_bytes_per_texel = factor_bytes;
      options.max_iterations = 50;
      SeamStitcher stitcher(page.seams, kSize, kSize, page.valid, options);
      const StitchStats s = stitcher.stitch(page.image);
      const size_t bound = SeamStitcher::bytes_bound(kTexels, 3, page.seams.size(), options);
      std::printf(
          "%s, factors within %.0f B/texel: %.2f unknowns a texel, %zu of %zu seams, %zu components (%zu "
          "factored), %zu values held at 0; peak %.1f B/texel, bound %.1f\n",
          in_tiles ? "in tiles" : "anywhere", factor_bytes, double(stitcher.unknowns()) / kTexels,
          stitcher.seams_used(), page.seams.size(), s.components, s.factored, s.held_at_zero,
          double(stitcher.peak_bytes()) / kTexels, double(bound) / kTexels);
      EXPECT_GT(stitcher.seams_over_budget(), 0u);
      EXPECT_GT(stitcher.unknowns(), kTexels / 2);
      EXPECT_GT(s.held_at_zero, 0u);
      if (in_tiles) {
        EXPECT_GT(s.factored, 0u);
      }
      EXPECT_LE(stitcher.factor_bytes(), static_cast<size_t>(factor_bytes * kTexels));
      EXPECT_LE(stitcher.peak_bytes(), bound);
    }
  }
}

TEST(SeamStitcher, OneChannelImages) {
  TwoCharts charts(1);
  const double step = largest_mismatch(charts.image, charts.seams);
  const StitchStats stats = SeamStitcher(charts.seams, charts.width, charts.height, charts.valid).stitch(charts.image);
  EXPECT_LT(largest_mismatch(charts.image, charts.seams), 1e-3 * step);
  EXPECT_GT(stats.texels_changed, 0u);
}

// A dark chart against one with a bright spike on its border: the fit overshoots below zero beside the spike, and a
// channel with no negative values keeps none.
TEST(SeamStitcher, NonNegativeImagesStayNonNegative) {
  TwoCharts charts(1);
  for (size_t t = 0; t < charts.valid.size(); ++t) charts.image.pixels[t] = 0.0f;
  charts.image.pixels[static_cast<size_t>(9) * charts.width + 24] = 100.0f;  // B's border, row 9
  charts.image.pixels[static_cast<size_t>(10) * charts.width + 13] = 50.0f;  // A's border, row 10
  const StitchStats stats = SeamStitcher(charts.seams, charts.width, charts.height, charts.valid).stitch(charts.image);
  EXPECT_GT(stats.texels_changed, 0u);
  EXPECT_LT(stats.mismatch_after, stats.mismatch_before);
  for (const float v : charts.image.pixels) EXPECT_GE(v, 0.0f);
}

// A lit chart against one in shadow (10 against 0), each side's lookups reading its own valid texels with weight
// 0.9 and a dilated texel with 0.1: the fit's cheapest way to agree takes A's dilated column far below 0 (to −30 and
// less). Those values are held at 0 and the others refit: nothing is negative and the lookups still agree. The
// residual of a least-squares fit with seam weight 1000 against texel weight 1 is about the change a valid texel
// makes (~5) over 1000; 0.01 of the brightness (~0.05 here) leaves a margin of ten. Clamping the unconstrained fit
// instead left the lookups 1.4 brightnesses apart on the Cornell box's short block.
TEST(SeamStitcher, ValuesTheFitWouldTakeBelowZeroAreHeldAtZeroAndTheSeamStillAgrees) {
  StitchOptions cg_only;
  cg_only.factor_budget = 0;
  for (const StitchOptions& options : {StitchOptions{}, cg_only}) {
    TwoCharts charts(1);
    for (size_t t = 0; t < charts.valid.size(); ++t) {
      if (charts.valid[t]) charts.image.pixels[t] = t % charts.width < 20 ? 10.0f : 0.0f;
    }
    dilate(charts.image, charts.valid, 2);
    charts.seams[0].a0.x = charts.seams[0].a1.x = 13.6;  // reads column 13 (valid, 0.9) and 14 (dilated, 0.1)
    charts.seams[0].b0.x = charts.seams[0].b1.x = 24.4;  // reads column 23 (dilated, 0.1) and 24 (valid, 0.9)
    SeamStitcher stitcher(charts.seams, charts.width, charts.height, charts.valid, options);
    const StitchStats stats = stitcher.stitch(charts.image);
    std::printf("lit against dark (%s): mismatch %.3g -> %.3g, %zu values held at 0\n",
                stats.factored ? "factored" : "CG", stats.mismatch_before, stats.mismatch_after, stats.held_at_zero);
    EXPECT_EQ(stats.factored, options.factor_budget > 0 ? 1u : 0u);
    EXPECT_TRUE(stats.converged);
    EXPECT_GT(stats.held_at_zero, 0u);
    for (const float v : charts.image.pixels) ASSERT_GE(v, 0.0f);
    EXPECT_GT(stats.mismatch_before, 1.0);
    EXPECT_LT(stats.mismatch_after, 0.01);
    // The same agreement by the test's own lookups, over the step of 10.
    const Seam& s = charts.seams[0];
    for (double t = 0; t <= 1; t += 1.0 / 64) {
      const double a = lookup(charts.image, {s.a0.x, s.a0.y + t * (s.a1.y - s.a0.y)}, 0);
      const double b = lookup(charts.image, {s.b0.x, s.b0.y + t * (s.b1.y - s.b0.y)}, 0);
      EXPECT_NEAR(a, b, 0.05) << "at t = " << t;
    }
  }
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
  SeamStitcher stitcher(seams, charts.width, charts.height, charts.valid);
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
  for (const double budget : {-1.0, std::numeric_limits<double>::quiet_NaN()}) {
    StitchOptions bad_budget;
    bad_budget.factor_budget = budget;
    EXPECT_THROW(SeamStitcher(charts.seams, charts.width, charts.height, charts.valid, bad_budget),
                 std::invalid_argument)
        << budget;
  }
  image::FloatImage wrong = charts.image;
  wrong.width = 10;
  EXPECT_THROW(stitcher.stitch(wrong), std::invalid_argument);
}

// ---- The test: a baked cube ----

// The inside of a closed 2 m cube unwrapped into six charts (add_box, facing inward), grey (albedo 0.5), lit by a
// point light at its centre. Every cube edge lies in a mirror plane of the scene (the plane through the edge and
// the centre swaps its two faces), so the irradiance, direct (I·h/r³) and indirect alike, is continuous across every
// edge; it also varies strongly across each face (from 1 at a face's centre to 0.35 at an edge's middle), so texels
// read at different distances from the edge on the two sides disagree. At 24² the charts are 6 × 9.75 texels (add_box's
// 3 × 2 layout), so one face's edge is 6 texels long on one side of a seam and 9.75 on the other, and the borders lie
// at half- and quarter-texel phases.
scene::Scene lit_cube_inside() {
  scene::Scene s;
  s.materials.push_back(test::lambert_material("grey", 0.5));
  test::add_box(s, "cube", {-1, -1, -1}, {1, 1, 1}, 0, /*inward=*/true);
  scene::Light l;
  l.type = scene::LightShape::point;
  l.position = {0, 0, 0};
  l.color = Rgb{1.0};
  s.lights = {l};
  return s;
}

constexpr int kCubeResolution = 24;

struct SeamNoise {
  double worst_ratio = 0;   // the largest |ΔY| / noise over the points
  double worst_mismatch = 0;  // the largest |ΔY| / brightness
  double rms_noise = 0;     // the RMS noise bound, relative
  size_t points = 0, above = 0;  // points checked, and above kSeamSigmas noises
  size_t above_one = 0;          // above one noise
};

// How many noises the two sides' lookups may differ by. A lookup is a weighted mean (weights summing to 1) of texels
// whose standard errors are at most σ_X, the largest the error image gives the valid texels in the 4 × 4 block
// around it (dilated texels are means of those), so the difference of the two independent sides has a standard
// error of at most √(σ_A² + σ_B²). The error image's σ is itself estimated from 8 replicas (7 degrees of freedom,
// test_scenes.h): 4 such errors are exceeded by a t₇ variable with probability 0.005. Stitched, every point must be
// within one noise (measured: 0.39 at most); unstitched, some must be beyond kSeamSigmas (measured: 119 of 828 points,
// up to 5.8), which noise alone would almost never give.
constexpr double kSeamSigmas = 4;

SeamNoise seam_noise(const image::FloatImage& irradiance, const image::FloatImage& error,
                     const std::vector<uint8_t>& valid, const std::vector<Seam>& seams, double brightness) {
  SeamNoise out;
  const int w = irradiance.width, h = irradiance.height;
  const auto sigma = [&](const Point2& p) {
    const int x0 = static_cast<int>(std::floor(p.x - 0.5)) - 1, y0 = static_cast<int>(std::floor(p.y - 0.5)) - 1;
    double worst = 0;
    for (int y = y0; y < y0 + 4; ++y) {
      for (int x = x0; x < x0 + 4; ++x) {
        if (x < 0 || y < 0 || x >= w || y >= h) continue;
        const size_t t = static_cast<size_t>(y) * w + x;
        if (valid[t]) worst = std::max(worst, static_cast<double>(error.pixels[t]));
      }
    }
    return worst;
  };
  double sum_sq = 0;
  for (const Seam& s : seams) {
    const double length = std::max(std::hypot(s.a1.x - s.a0.x, s.a1.y - s.a0.y), std::hypot(s.b1.x - s.b0.x, s.b1.y - s.b0.y));
    const int n = static_cast<int>(std::ceil(8 * length));  // 8 points a texel: finer than the stitcher's 2
    for (int k = 0; k <= n; ++k) {
      const double t = static_cast<double>(k) / n;
      const Point2 a{s.a0.x + t * (s.a1.x - s.a0.x), s.a0.y + t * (s.a1.y - s.a0.y)};
      const Point2 b{s.b0.x + t * (s.b1.x - s.b0.x), s.b0.y + t * (s.b1.y - s.b0.y)};
      const auto y = [&](const Point2& p) {
        return luminance(Rgb(lookup(irradiance, p, 0), lookup(irradiance, p, 1), lookup(irradiance, p, 2)));
      };
      const double mismatch = std::abs(y(a) - y(b)) / brightness;
      const double noise = std::hypot(sigma(a), sigma(b));
      sum_sq += noise * noise;
      ++out.points;
      out.worst_mismatch = std::max(out.worst_mismatch, mismatch);
      out.worst_ratio = std::max(out.worst_ratio, mismatch / noise);
      if (mismatch > kSeamSigmas * noise) ++out.above;
      if (mismatch > noise) ++out.above_one;
    }
  }
  out.rms_noise = out.points ? std::sqrt(sum_sq / static_cast<double>(out.points)) : 0;
  return out;
}

LightmapBakeResult bake_cube(bool stitch) {
  LightmapBakeInput in = test::lightmap_input(lit_cube_inside(), kCubeResolution, 0.01);
  in.padding = 2;
  in.error_metric = ErrorMetric::lightmap;  // the error image in units of the brightness, as the mismatch
  in.stitch_seams = stitch;
  in.radiance = in.ao = true;
  return bake_lightmaps(in);
}

SeamNoise cube_seams(const LightmapBakeResult& r, bool stitch, double& reported_before, double& reported_after) {
  const scene::Scene s = lit_cube_inside();
  const image::FloatImage irradiance = test::exr_output(r, "cube_irradiance.exr");
  const image::FloatImage error = test::exr_output(r, "cube_error.exr");
  const image::FloatImage validity = test::exr_output(r, "cube_validity.exr");
  std::vector<uint8_t> valid(validity.pixels.size());
  double sum = 0;
  size_t n = 0;
  for (size_t t = 0; t < valid.size(); ++t) {
    valid[t] = validity.pixels[t] > 0.5f;
    if (!valid[t]) continue;
    sum += luminance(Rgb(irradiance.pixels[3 * t], irradiance.pixels[3 * t + 1], irradiance.pixels[3 * t + 2]));
    ++n;
  }
  const std::vector<Seam> seams = find_seams(s, "cube", kCubeResolution, kCubeResolution).seams;
  EXPECT_EQ(seams.size(), 12u);
  const nlohmann::json report = nlohmann::json::parse(test::find_output(r, "report.json").bytes);
  const nlohmann::json& entry = report["lightmaps"][0]["seams"];
  EXPECT_EQ(entry["stitched"].get<bool>(), stitch);
  reported_before = stitch ? entry["mismatch_max_before"].get<double>() : -1;
  reported_after = stitch ? entry["mismatch_max_after"].get<double>() : -1;
  if (stitch) {
    EXPECT_EQ(entry["edges"].get<size_t>(), 12u);
    EXPECT_GT(entry["texels_changed"].get<size_t>(), 0u);
    EXPECT_TRUE(entry["converged"].get<bool>());
    EXPECT_GE(entry["components"].get<size_t>(), 1u);
    EXPECT_EQ(entry["factored_components"].get<size_t>(), entry["components"].get<size_t>());
    // The stitcher's bytes are in the bake's held peak, beside the page's results it stitches.
    const uint64_t seam_bytes = entry["peak_bytes"].get<uint64_t>();
    EXPECT_GE(seam_bytes, static_cast<uint64_t>(kCubeResolution * kCubeResolution));  // its validity map at least
    EXPECT_GE(
        report["memory"]["held_peak_bytes"].get<uint64_t>(),
        seam_bytes + static_cast<uint64_t>(kCubeResolution * kCubeResolution) *
                         LightmapResults::bytes_per_texel({/*ao=*/true, /*directional=*/false, /*radiance=*/true}));
    std::printf("stitched: %zu components, %zu factored, %d CG iterations, %.3g s\n", entry["components"].get<size_t>(),
                entry["factored_components"].get<size_t>(), entry["iterations"].get<int>(),
                entry["seconds"].get<double>());
  }
  return seam_noise(irradiance, error, valid, seams, sum / static_cast<double>(n));
}

TEST(SeamStitching, BakedCubeSidesAgreeWithinTheNoiseAndDoNotWithoutIt) {
  double before = 0, after = 0, unused = 0;
  const LightmapBakeResult with = bake_cube(true), without = bake_cube(false);
  const SeamNoise stitched = cube_seams(with, true, before, after);
  const SeamNoise raw = cube_seams(without, false, unused, unused);
  std::printf("cube 24^2, target 0.01: noise (RMS, relative) %.3g; largest mismatch stitched %.3g (%.3g noises), "
              "unstitched %.3g (%.3g noises, %zu of %zu points above %g); report: %.3g -> %.3g\n",
              stitched.rms_noise, stitched.worst_mismatch, stitched.worst_ratio, raw.worst_mismatch, raw.worst_ratio,
              raw.above, raw.points, kSeamSigmas, before, after);
  EXPECT_EQ(stitched.above_one, 0u) << "largest " << stitched.worst_ratio << " noises";
  // The teeth: the same bake without stitching differs by more than the noise along its seams.
  EXPECT_GT(raw.above, 0u) << "largest " << raw.worst_ratio << " noises";
  // Validity and error are the same bytes either way; the radiance and AO are stitched too.
  for (const char* name : {"cube_validity.exr", "cube_error.exr"}) {
    EXPECT_EQ(test::find_output(with, name).bytes, test::find_output(without, name).bytes) << name;
  }
  for (const char* name : {"cube_radiance.exr", "cube_ao.exr"}) {
    EXPECT_NE(test::find_output(with, name).bytes, test::find_output(without, name).bytes) << name;
    const image::FloatImage img = test::exr_output(with, name);
    for (const float v : img.pixels) ASSERT_TRUE(std::isfinite(v) && v >= 0) << name;
  }
}

// The bundled Cornell box (its two blocks have five faces each, charts of one mesh: their edges are seams): every
// lightmap with seams ends with a smaller mismatch, and the report says so. Prints the figures.
TEST(SeamStitching, CornellBoxBlocks) {
  LightmapBakeInput in = test::lightmap_input(test::cornell_box(), 32, 0.05);
  in.padding = 2;
  in.stitch_seams = true;
  const LightmapBakeResult r = bake_lightmaps(in);
  const nlohmann::json report = nlohmann::json::parse(test::find_output(r, "report.json").bytes);
  size_t with_seams = 0;
  for (const nlohmann::json& m : report["lightmaps"]) {
    const nlohmann::json& e = m["seams"];
    ASSERT_TRUE(e["stitched"].get<bool>());
    if (e["edges"].get<size_t>() == 0) continue;
    ++with_seams;
    std::printf(
        "cornell box 32^2 %s: %zu seam edges, %zu texels changed, %zu values held at 0, mismatch %.3g -> %.3g "
        "(RMS %.3g -> %.3g), %zu of %zu components factored, %.3g s\n",
        m["name"].get<std::string>().c_str(), e["edges"].get<size_t>(), e["texels_changed"].get<size_t>(),
        e["values_held_at_zero"].get<size_t>(), e["mismatch_max_before"].get<double>(),
        e["mismatch_max_after"].get<double>(), e["mismatch_rms_before"].get<double>(),
        e["mismatch_rms_after"].get<double>(), e["factored_components"].get<size_t>(), e["components"].get<size_t>(),
        e["seconds"].get<double>());
    // The steps across the blocks' edges are 3.6 and 8.8 brightnesses; the fit leaves about a thousandth of a step
    // (seam weight 1000 against texel weight 1), 0.009 at most; twice that.
    EXPECT_LT(e["mismatch_max_after"].get<double>(), 0.02);
    EXPECT_TRUE(e["converged"].get<bool>());
  }
  EXPECT_GE(with_seams, 2u);  // the short and the tall block
}

}  // namespace
}  // namespace kiln::lightmap
