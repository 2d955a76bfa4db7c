// Rect and disk area lights and the polygon irradiance reference: irradiance estimated from the lights' samples
// against Lambert's exact formula and the disk's closed form; sample_li against pdf_li by χ² (spherical-rectangle and
// area sampling, disks); the singular cases.
#include "bakers/scene/area_lights.h"

#include <gtest/gtest.h>

#include <cmath>

#include "bakers/scene/polygon_irradiance.h"
#include "bakers/scene/spherical_geometry.h"
#include "tests/scene/light_test_util.h"
#include "tests/support/tolerance.h"

namespace kiln::scene {
namespace {

// Family of χ² tests in this file (Šidák-corrected to a 1% family-wise false-rejection rate).
constexpr int kChi2Tests = 6;

// Differential area to a parallel rectangle a × b at height h, with the point under a corner (Howell's catalogue,
// configuration B-3): F = 1/(2π) [A/√(1+A²) atan(B/√(1+A²)) + B/√(1+B²) atan(A/√(1+B²))], A = a/h, B = b/h, and
// the projected solid angle is π F.
double parallel_rect_corner(double a, double b, double h) {
  const double A = a / h, B = b / h;
  const double sa = std::sqrt(1 + A * A), sb = std::sqrt(1 + B * B);
  return 0.5 * (A / sa * std::atan(B / sa) + B / sb * std::atan(A / sb));
}

TEST(PolygonIrradiance, MatchesTheParallelRectangleClosedForm) {
  const double a = 2.0, b = 0.7, h = 1.3;
  const std::vector<Vec3> rect = {{0, h, 0}, {a, h, 0}, {a, h, b}, {0, h, b}};
  // Both are closed forms evaluated in double: they agree to rounding.
  EXPECT_TRUE(
      test::close(polygon_projected_solid_angle(rect, {0, 0, 0}, {0, 1, 0}), parallel_rect_corner(a, b, h), 1e-13));
  // Reversed winding: the same.
  const std::vector<Vec3> reversed(rect.rbegin(), rect.rend());
  EXPECT_TRUE(
      test::close(polygon_projected_solid_angle(reversed, {0, 0, 0}, {0, 1, 0}), parallel_rect_corner(a, b, h), 1e-13));
  // Superposition: a point under the middle of a rectangle sees four corner rectangles.
  const std::vector<Vec3> big = {{-1, h, -0.5}, {1.5, h, -0.5}, {1.5, h, 0.8}, {-1, h, 0.8}};
  const double four = parallel_rect_corner(1, 0.5, h) + parallel_rect_corner(1.5, 0.5, h) +
                      parallel_rect_corner(1, 0.8, h) + parallel_rect_corner(1.5, 0.8, h);
  EXPECT_TRUE(test::close(polygon_projected_solid_angle(big, {0, 0, 0}, {0, 1, 0}), four, 1e-13));
}

TEST(PolygonIrradiance, ClipsAtTheHorizon) {
  // A tilted rectangle crossing the horizon of p = 0, n = +Y: the formula on the clipped polygon equals the formula
  // on the part above the horizon, constructed here by hand from the crossing points.
  const Vec3 c0{-1, -0.5, 2}, c1{1, -0.5, 2}, c2{1, 1.5, 1}, c3{-1, 1.5, 1};
  // The edges c1→c2 and c3→c0 cross y = 0 at t = 0.25 from the lower end.
  const Vec3 m1 = c1 + (c2 - c1) * 0.25, m3 = c0 + (c3 - c0) * 0.25;
  const double full = polygon_projected_solid_angle({c0, c1, c2, c3}, {}, {0, 1, 0});
  const double part = polygon_projected_solid_angle({m3, m1, c2, c3}, {}, {0, 1, 0});
  EXPECT_TRUE(test::close(full, part, 1e-14));
  EXPECT_GT(full, 0.0);
  // Entirely below: 0.
  EXPECT_EQ(polygon_projected_solid_angle({{0, -1, 0}, {1, -1, 0}, {1, -1, 1}}, {}, {0, 1, 0}), 0.0);
}

std::vector<Vec3> corners(const RectLight& r) { return {r.corner(0), r.corner(1), r.corner(2), r.corner(3)}; }

// The estimator's mean within 5 of its own standard errors of the exact value (a false failure about once in
// 1.7 million runs): sampling adds no discretisation, and Lambert's formula is exact.
void expect_irradiance(const LightSource& light, const Vec3& p, const Vec3& n, double exact, uint64_t seed,
                       const std::string& what, int64_t samples = 100000) {
  const auto e = test::estimate_irradiance(light, p, n, samples, seed);
  ASSERT_TRUE(e.all_finite) << what;
  EXPECT_NEAR(e.mean, exact, 5 * e.standard_error + 1e-12 * exact) << what << ": standard error " << e.standard_error;
}

TEST(RectLight, IrradianceMatchesLambertsFormula) {
  // A 2 × 1 rectangle 1.5 above the origin facing down, radiance (4, 2, 1).
  const RectLight rect({0.3, 1.5, -0.2}, {2, 0, 0}, {0, 0, 1}, {0, -1, 0}, Rgb{4, 2, 1}, false);
  struct Case {
    Vec3 p, n;
    const char* what;
  };
  const Case cases[] = {
      {{0, 0, 0}, {0, 1, 0}, "below, facing it"},
      {{0.5, 1.45, 0.1}, {0, 1, 0}, "0.05 below (large solid angle)"},
      {{3, 0.2, 1}, normalize(Vec3{-1, 1, 0}), "off to the side, tilted"},
      {{0, 0, 0}, normalize(Vec3{1, 0.2, 0}), "nearly edge-on normal: the light straddles the horizon"},
      {{1000, -800, 600}, normalize(Vec3{-1, 1, -0.5}), "far away (area sampling)"},
  };
  uint64_t seed = 100;
  for (const Case& c : cases) {
    const double exact = 4 * polygon_projected_solid_angle(corners(rect), c.p, c.n);
    expect_irradiance(rect, c.p, c.n, exact, ++seed, c.what);
  }
  EXPECT_TRUE(rect.uses_spherical_sampling({0, 0, 0}));
  EXPECT_FALSE(rect.uses_spherical_sampling({1000, -800, 600}));
  // Behind a one-sided light: nothing; two-sided: the mirror image's irradiance.
  EXPECT_FALSE(rect.sample_li({0, 3, 0}, {0, -1, 0}, {0.5, 0.5}));
  const RectLight both({0.3, 1.5, -0.2}, {2, 0, 0}, {0, 0, 1}, {0, -1, 0}, Rgb{4, 2, 1}, true);
  expect_irradiance(both, {0, 3, 0}, {0, -1, 0}, 4 * polygon_projected_solid_angle(corners(rect), {0, 0, 0}, {0, 1, 0}),
                    201, "two-sided, from above");
  // Power: π L A.
  EXPECT_TRUE(test::close(rect.power(1).r, kPi * 4 * 2, 1e-15));
  EXPECT_TRUE(test::close(both.power(1).r, 2 * kPi * 4 * 2, 1e-15));
}

TEST(RectLight, ParallelogramIsSampledByArea) {
  const RectLight para({0, 2, 0}, {2, 0, 0}, {0.8, 0, 1}, {0, -1, 0}, Rgb{1}, false);
  EXPECT_FALSE(para.uses_spherical_sampling({0, 0, 0}));
  EXPECT_TRUE(test::close(para.area(), 2.0, 1e-15));
  expect_irradiance(para, {0.2, 0, 0.1}, {0, 1, 0},
                    polygon_projected_solid_angle(corners(para), {0.2, 0, 0.1}, {0, 1, 0}), 301, "parallelogram");
}

// Cells about the direction to the light's centre, out to 1.1 × the widest angle to its boundary.
test::DirectionChi2Options cells_around(const Vec3& p, const std::vector<Vec3>& boundary, const Vec3& centre,
                                        uint64_t seed) {
  test::DirectionChi2Options o;
  o.axis = normalize(centre - p);
  double widest = 0;
  for (const Vec3& b : boundary) widest = std::max(widest, angle_between(o.axis, normalize(b - p)));
  o.theta_max = std::min(kPi, 1.1 * widest);
  o.n_theta = 12;
  o.n_phi = 24;
  o.samples = 200000;
  o.seed = seed;
  o.test_count = kChi2Tests;
  o.shape_only = true;  // a lit side: no sample fails, and every direction reaching the light is in the cells
  return o;
}

void expect_chi2(const LightSource& light, const Vec3& p, const Vec3& n, const test::DirectionChi2Options& o,
                 const std::string& what) {
  const auto r = test::direction_chi2(
      test::light_sampler_at(light, p, n), [&](const Vec3& w) { return light.pdf_li(p, n, w, {}); }, o);
  EXPECT_TRUE(r.passed) << what << ": " << r.details;
  // The cells hold the whole light, so the density integrates to 1 over them, up to the adaptive quadrature's
  // error along the light's outline (a jump of the pdf that its error estimate under-reports: measured up to
  // 1.8e-4 for the disk's curved outline on this 12 × 24 grid, 2e-5 for the rectangles). (On a 16 × 32 grid the
  // same harness passes 2 million samples of every light here: its expected counts are not what limits the test.)
  EXPECT_NEAR(r.pdf_integral, 1.0, 5e-4) << what << ": " << r.details;
}

TEST(RectLight, SamplingMatchesPdfLi) {
  const RectLight rect({0, 1, 0}, {2, 0, 0}, {0, 0, 1.5}, {0, -1, 0}, Rgb{1}, false);
  const Vec3 centre{0, 1, 0};
  const Vec3 near{0.4, 0.7, 0.2}, far{2, -1, 3};
  ASSERT_TRUE(rect.uses_spherical_sampling(near));
  expect_chi2(rect, near, {0, 1, 0}, cells_around(near, corners(rect), centre, 11), "spherical rectangle, near");
  expect_chi2(rect, far, {0, 1, 0}, cells_around(far, corners(rect), centre, 12), "spherical rectangle, oblique");
  const RectLight small({0, 1, 0}, {0.002, 0, 0}, {0, 0, 0.001}, {0, -1, 0}, Rgb{1}, false);
  ASSERT_FALSE(small.uses_spherical_sampling({0, 0, 0}));
  expect_chi2(small, {0, 0, 0}, {0, 1, 0}, cells_around({0, 0, 0}, corners(small), centre, 13), "area sampling");
}

TEST(RectLight, Chi2RejectsAWrongDensity) {
  // The harness has power: the spherical rectangle's samples tested against the area-sampling density (d²/(A cos),
  // correct in integral but not in shape) must be rejected at this light's size.
  const RectLight rect({0, 1, 0}, {2, 0, 0}, {0, 0, 1.5}, {0, -1, 0}, Rgb{1}, false);
  const Vec3 p{0.4, 0.7, 0.2};
  const auto wrong = [&](const Vec3& w) {
    const auto hit = rect.intersect(p, w, kInfinity);
    return hit ? hit->distance * hit->distance / (rect.area() * std::fabs(w.y)) : 0.0;
  };
  auto o = cells_around(p, corners(rect), {0, 1, 0}, 14);
  const auto r = test::direction_chi2(test::light_sampler_at(rect, p, {0, 1, 0}), wrong, o);
  EXPECT_LT(r.p_value, 1e-12) << r.details;
}

TEST(RectLight, SingularCasesStayFinite) {
  const RectLight rect({0, 1, 0}, {1, 0, 0}, {0, 0, 1}, {0, -1, 0}, Rgb{1}, true);
  // p on the light's plane (inside and outside the rectangle): edge-on, no light, pdf 0.
  for (const Vec3& p : {Vec3{0, 1, 0}, Vec3{3, 1, 0}}) {
    EXPECT_FALSE(rect.sample_li(p, {0, 1, 0}, {0.3, 0.3}));
    EXPECT_EQ(rect.pdf_li(p, {0, 1, 0}, {0, 1, 0}, {}), 0.0);
    EXPECT_EQ(rect.solid_angle(p), 0.0);
  }
  // Grazing: p a hair off the plane, beside the light; and a hair below its centre (solid angle → 2π).
  for (const Vec3& p : {Vec3{3, 1 - 1e-12, 0}, Vec3{0.1, 1 - 1e-13, 0.1}}) {
    for (double u0 : {0.0, 0.3, std::nextafter(1.0, 0.0)}) {
      for (double u1 : {0.0, 0.7, std::nextafter(1.0, 0.0)}) {
        const auto s = rect.sample_li(p, {0, 1, 0}, {u0, u1});
        if (!s) continue;
        EXPECT_TRUE(is_finite(s->wi) && std::isfinite(s->pdf) && s->pdf > 0 && std::isfinite(s->distance));
      }
    }
  }
  // Zero area (parallel edges), black radiance, NaN radiance: black lights with zero power.
  for (const RectLight& dead : {RectLight({0, 1, 0}, {1, 0, 0}, {2, 0, 0}, {0, -1, 0}, Rgb{1}, false),
                                RectLight({0, 1, 0}, {1, 0, 0}, {0, 0, 1}, {0, -1, 0}, Rgb{0}, false),
                                RectLight({0, 1, 0}, {1, 0, 0}, {0, 0, 1}, {0, -1, 0}, Rgb{std::nan("")}, false)}) {
    EXPECT_FALSE(dead.sample_li({0, 0, 0}, {0, 1, 0}, {0.5, 0.5}));
    EXPECT_EQ(dead.pdf_li({0, 0, 0}, {0, 1, 0}, {0, 1, 0}, {}), 0.0);
    EXPECT_TRUE(dead.power(1).is_black());
  }
  // intersect: through the centre, outside, parallel to the plane.
  const auto hit = rect.intersect({0, 0, 0}, {0, 1, 0}, kInfinity);
  ASSERT_TRUE(hit);
  EXPECT_DOUBLE_EQ(hit->distance, 1.0);
  EXPECT_FALSE(rect.intersect({0, 0, 0}, normalize(Vec3{1, 1, 0}), kInfinity));
  EXPECT_FALSE(rect.intersect({0, 0, 0}, {1, 0, 0}, kInfinity));
  EXPECT_FALSE(rect.intersect({0, 0, 0}, {0, 1, 0}, 0.5));  // beyond t_max
}

TEST(DiskLight, OnAxisClosedForm) {
  // E = π L r² / (r² + h²) on the axis (the form factor of a parallel coaxial disk).
  const double r = 0.8, h = 1.7;
  const DiskLight disk({0, h, 0}, {0, -1, 0}, r, Rgb{3}, false);
  expect_irradiance(disk, {0, 0, 0}, {0, 1, 0}, kPi * 3 * r * r / (r * r + h * h), 401, "on axis");
  expect_irradiance(disk, {0, h - 0.01, 0}, {0, 1, 0}, kPi * 3 * r * r / (r * r + 0.01 * 0.01), 402,
                    "on axis, 0.01 below");
  EXPECT_TRUE(test::close(disk.power(1).r, kPi * 3 * kPi * r * r, 1e-15));
  EXPECT_FALSE(disk.sample_li({0, 2, 0}, {0, -1, 0}, {0.5, 0.5}));  // behind a one-sided disk
}

std::vector<Vec3> regular_polygon(const Vec3& c, double radius, int sides) {
  std::vector<Vec3> out;
  for (int k = 0; k < sides; ++k) {
    const double phi = 2 * kPi * k / sides;
    out.push_back(c + Vec3{radius * std::cos(phi), 0, radius * std::sin(phi)});
  }
  return out;
}

TEST(DiskLight, OffAxisBetweenInscribedAndCircumscribed256Gons) {
  // Off the axis there is no short closed form; the disk lies between its inscribed and circumscribed 256-gons, so
  // (all of it above p's horizon, non-negative integrand) its projected solid angle lies between theirs — a bracket
  // about 1e-4 wide, to which the estimator's 5σ is added.
  const double r = 1.0;
  const Vec3 c{0, 2, 0};
  const DiskLight disk(c, {0, -1, 0}, r, Rgb{1}, false);
  const Vec3 p{1.5, 0.3, -0.7}, n = normalize(Vec3{-0.3, 1, 0.2});
  const double lo = polygon_projected_solid_angle(regular_polygon(c, r, 256), p, n);
  const double hi = polygon_projected_solid_angle(regular_polygon(c, r / std::cos(kPi / 256), 256), p, n);
  ASSERT_LT(hi - lo, 2e-4 * hi);
  const auto e = test::estimate_irradiance(disk, p, n, 200000, 501);
  ASSERT_TRUE(e.all_finite);
  EXPECT_GT(e.mean, lo - 5 * e.standard_error);
  EXPECT_LT(e.mean, hi + 5 * e.standard_error);
}

TEST(DiskLight, SamplingMatchesPdfLi) {
  const Vec3 c{0, 1, 0};
  const DiskLight disk(c, {0, -1, 0}, 1.0, Rgb{1}, false);
  for (const Vec3& p : {Vec3{0.3, 0.6, 0.1}, Vec3{2.5, 0.2, -1.0}}) {
    auto o =
        cells_around(p, regular_polygon(c, 1.0 / std::cos(kPi / 64), 64), c, 600 + static_cast<uint64_t>(p.x * 10));
    expect_chi2(disk, p, {0, 1, 0}, o, "disk");
  }
}

TEST(DiskLight, SingularCasesStayFinite) {
  const DiskLight disk({0, 1, 0}, {0, -1, 0}, 0.5, Rgb{1}, true);
  EXPECT_FALSE(disk.sample_li({0, 1, 0}, {0, 1, 0}, {0.5, 0.5}));  // p at the centre, on the plane
  EXPECT_FALSE(disk.sample_li({2, 1, 0}, {0, 1, 0}, {0.5, 0.5}));  // on the plane, outside
  EXPECT_EQ(disk.pdf_li({2, 1, 0}, {0, 1, 0}, {-1, 0, 0}, {}), 0.0);
  // Zero radius, zero normal, NaN radiance: black.
  for (const DiskLight& dead :
       {DiskLight({0, 1, 0}, {0, -1, 0}, 0.0, Rgb{1}, false), DiskLight({0, 1, 0}, {0, 0, 0}, 1.0, Rgb{1}, false),
        DiskLight({0, 1, 0}, {0, -1, 0}, 1.0, Rgb{std::nan("")}, false)}) {
    EXPECT_FALSE(dead.sample_li({0, 0, 0}, {0, 1, 0}, {0.5, 0.5}));
    EXPECT_TRUE(dead.power(1).is_black());
  }
  // A hair below the centre: finite samples with finite densities.
  for (double u : {0.0, 0.5, std::nextafter(1.0, 0.0)}) {
    const auto s = disk.sample_li({0, 1 - 1e-14, 0}, {0, 1, 0}, {u, 1 - u});
    if (s) {
      EXPECT_TRUE(std::isfinite(s->pdf) && is_finite(s->wi));
    }
  }
}

}  // namespace
}  // namespace kiln::scene
