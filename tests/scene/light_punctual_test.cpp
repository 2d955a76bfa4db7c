// Point, spot and directional lights, and the sun disc: irradiance against closed forms, the spot's glTF falloff and
// power, and the sun's sampling against pdf_li (χ²), with a 0.5° sun for the tiny-disc case.
#include "bakers/scene/punctual_lights.h"

#include <gtest/gtest.h>

#include <cmath>

#include "tests/scene/light_test_util.h"
#include "tests/support/tolerance.h"

namespace kiln::scene {
namespace {

constexpr double kDeg = kPi / 180.0;

TEST(PointLight, IrradianceIsIntensityCosOverDistanceSquared) {
  const PointLight light({1, 4, -2}, Rgb{3, 2, 1});
  const Vec3 p{0.5, 0.0, 0.25}, n = normalize(Vec3{0.2, 1, 0.1});
  const auto s = light.sample_li(p, n, {0.3, 0.7});
  ASSERT_TRUE(s);
  EXPECT_TRUE(s->delta);
  EXPECT_EQ(s->pdf, 0.0);
  const Vec3 d = Vec3{1, 4, -2} - p;
  const double r2 = dot(d, d), cos_theta = dot(normalize(d), n);
  // Closed form, one sample (a delta light has no variance): agreement to rounding (1e-12 relative).
  EXPECT_TRUE(test::close(s->irradiance(dot(s->wi, n)).r, 3 * cos_theta / r2, 1e-12));
  EXPECT_TRUE(test::close(s->irradiance(dot(s->wi, n)).b, 1 * cos_theta / r2, 1e-12));
  EXPECT_TRUE(test::close(s->distance, std::sqrt(r2), 1e-14));
  EXPECT_EQ(s->point, (Vec3{1, 4, -2}));
  EXPECT_TRUE(test::close(light.power(1).g, 8 * kPi, 1e-15));
  // p at the light: no direction, no light (instead of an infinite 1/r²).
  EXPECT_FALSE(light.sample_li({1, 4, -2}, n, {0.5, 0.5}));
  // r² underflowing/overflowing I/r²: still no NaN or Inf.
  const auto near = light.sample_li({1, 4, -2 + 1e-160}, n, {0.5, 0.5});
  EXPECT_TRUE(!near || near->Li.is_finite());
}

TEST(SpotLight, GltfFalloffAndPower) {
  const double inner = 20 * kDeg, outer = 40 * kDeg;
  const SpotLight spot({0, 3, 0}, {0, -2, 0}, Rgb{5}, inner, outer);
  // KHR_lights_punctual: a = clamp((cos − cos_o)/(cos_i − cos_o), 0, 1)²; exact values at the ends and the middle.
  EXPECT_DOUBLE_EQ(spot.falloff(1.0), 1.0);
  EXPECT_DOUBLE_EQ(spot.falloff(std::cos(inner)), 1.0);
  EXPECT_DOUBLE_EQ(spot.falloff(std::cos(outer)), 0.0);
  EXPECT_NEAR(spot.falloff(0.5 * (std::cos(inner) + std::cos(outer))), 0.25, 1e-15);
  // Below the light on its axis: I / r².
  const auto s = spot.sample_li({0, 0, 0}, {0, 1, 0}, {0, 0});
  ASSERT_TRUE(s);
  EXPECT_TRUE(test::close(s->Li.r, 5.0 / 9.0, 1e-14));
  // At 30° off the axis: I a(cos 30°) cos 30° / r² with r = 3 / cos 30°.
  const Vec3 p{3 * std::tan(30 * kDeg), 0, 0};
  const auto s30 = spot.sample_li(p, {0, 1, 0}, {0, 0});
  ASSERT_TRUE(s30);
  const double c = std::cos(30 * kDeg), r2 = 9.0 / (c * c);
  const double a = std::pow((c - std::cos(outer)) / (std::cos(inner) - std::cos(outer)), 2);
  EXPECT_TRUE(test::close(s30->irradiance(dot(s30->wi, Vec3{0, 1, 0})).r, 5 * a * c / r2, 1e-12));
  // Outside the outer cone: nothing.
  EXPECT_FALSE(spot.sample_li({3 * std::tan(45 * kDeg), 0, 0}, {0, 1, 0}, {0, 0}));
  // Power = I ∫ a dω against a Gauss–Legendre quadrature of the falloff with breakpoints at both cone angles, where
  // the integrand has its kinks (the rule is then exact to ~1e-12 for these smooth pieces).
  const test::DirectionRule rule = test::direction_rule({0.0, inner, outer, kPi}, {0.0, 2 * kPi}, 4, 8);
  const double q = test::integrate(rule, [&](const Vec3& w) { return spot.falloff(w.z); });
  EXPECT_TRUE(test::close(spot.power(1).r, 5 * q, 1e-10));
  // θ_inner ≥ θ_outer (invalid in glTF): the hard cut at θ_outer, never a division by zero.
  const SpotLight hard({0, 0, 0}, {0, 0, 1}, Rgb{1}, 0.5, 0.5);
  EXPECT_EQ(hard.falloff(std::cos(0.49)), 1.0);
  EXPECT_EQ(hard.falloff(std::cos(0.51)), 0.0);
  EXPECT_TRUE(test::close(hard.power(1).r, 2 * kPi * (1 - std::cos(0.5)), 1e-14));
  // A zero axis: a black light.
  EXPECT_FALSE(SpotLight({0, 0, 0}, {0, 0, 0}, Rgb{1}, 0.1, 0.2).sample_li({0, -1, 0}, {0, 1, 0}, {0, 0}));
}

TEST(DirectionalLight, DeltaDirectionGivesECosTheta) {
  const DirectionalLight sun({0, -1, -1}, Rgb{2, 1, 0.5}, 0.0);
  EXPECT_TRUE(sun.is_delta());
  EXPECT_TRUE(sun.is_infinite());
  const Vec3 n = normalize(Vec3{0, 1, 0.3});
  const auto s = sun.sample_li({}, n, {0.1, 0.9});
  ASSERT_TRUE(s);
  EXPECT_TRUE(std::isinf(s->distance));
  EXPECT_TRUE(test::close(s->irradiance(dot(s->wi, n)).r, 2 * dot(normalize(Vec3{0, 1, 1}), n), 1e-14));
  EXPECT_EQ(sun.pdf_li({}, n, s->wi, {}), 0.0);  // delta: a BSDF ray never hits it
  EXPECT_TRUE(sun.Le({}, s->wi, {}).is_black());
}

// The sun disc: uniform radiance over a cone of half-angle θ_max with E = color at normal incidence. For a disc
// entirely above the horizon, ∫ L (n·ω) dω = n · (L ∫ ω dω) = E cos θ exactly (the cone's mean direction is its axis).
void check_sun(double diameter_deg, uint64_t seed) {
  const Vec3 travel = normalize(Vec3{0.3, -1, 0.2});
  const DirectionalLight sun(travel, Rgb{1000, 800, 600}, diameter_deg * kDeg);
  ASSERT_FALSE(sun.is_delta());
  ASSERT_EQ(sun.kind(), LightSamplerKind::sun);
  const double theta_max = 0.5 * diameter_deg * kDeg;
  EXPECT_TRUE(test::close(sun.cone_solid_angle(), 2 * kPi * (1 - std::cos(theta_max)), 1e-9));
  for (double tilt_deg : {0.0, 40.0}) {
    // A normal tilted away from the sun's direction by tilt_deg (still with the whole disc above the horizon).
    const Vec3 to_sun = -travel;
    const Frame f = Frame::from_normal(to_sun);
    const Vec3 n = normalize(to_sun * std::cos(tilt_deg * kDeg) + f.s * std::sin(tilt_deg * kDeg));
    const auto e = test::estimate_irradiance(sun, {}, n, 200000, seed);
    ASSERT_TRUE(e.all_finite);
    const double exact = 1000 * std::cos(tilt_deg * kDeg);
    // 5 standard errors of the estimator itself (a false failure about once in 1.7 million runs); no discretisation.
    EXPECT_NEAR(e.mean, exact, 5 * e.standard_error + 1e-9 * exact)
        << diameter_deg << "° sun, tilt " << tilt_deg << "°, standard error " << e.standard_error;
  }
  // sample_li against pdf_li in cells about the sun's direction out to 1.5 θ_max (the rim is inside the cells).
  test::DirectionChi2Options o;
  o.axis = -travel;
  o.theta_max = 1.5 * theta_max;
  o.n_theta = 12;
  o.n_phi = 24;
  o.samples = 100000;
  o.test_count = 2;
  o.seed = seed;
  o.shape_only = true;  // the cone lies inside the cells and sampling never fails
  const Vec3 n{0, 1, 0};
  const auto r = test::direction_chi2(
      test::light_sampler_at(sun, {}, n), [&](const Vec3& w) { return sun.pdf_li({}, n, w, {}); }, o);
  EXPECT_TRUE(r.passed) << diameter_deg << "° sun: " << r.details;
  EXPECT_EQ(r.failures, 0);
  // The cells hold the whole cone: ∫ pdf = 1, to the quadrature's error at the cone's rim (a jump of the pdf; the
  // harness integrates such outlines to ~1e-5, see light_area_test).
  EXPECT_NEAR(r.pdf_integral, 1.0, 1e-4) << r.details;
  // Le inside the cone is the disc radiance E/(π sin² θ_max); outside, nothing.
  const double L = 1000 / (kPi * std::pow(std::sin(theta_max), 2));
  EXPECT_TRUE(test::close(sun.Le({}, -travel, {}).r, L, 1e-9));
  const Vec3 outside = normalize(-travel + Frame::from_normal(-travel).s * std::tan(1.01 * theta_max));
  EXPECT_TRUE(sun.Le({}, outside, {}).is_black());
  EXPECT_EQ(sun.pdf_li({}, n, outside, {}), 0.0);
}

TEST(DirectionalLight, SunDiscTenDegrees) { check_sun(10.0, 21); }
// The sun's real size: a cone of 0.25° half-angle, where 1 − cos θ_max ≈ 9.5e-6 must not lose its digits.
TEST(DirectionalLight, SunDiscHalfDegree) { check_sun(0.5, 23); }

TEST(DirectionalLight, DegenerateInputsAreBlackOrDelta) {
  // A zero direction: black, never NaN.
  const DirectionalLight none({0, 0, 0}, Rgb{1}, 0.01);
  EXPECT_FALSE(none.sample_li({}, {0, 1, 0}, {0.5, 0.5}));
  EXPECT_TRUE(none.power(1).is_black());
  // A diameter so small that sin² θ_max underflows: a delta direction, finite.
  const DirectionalLight tiny({0, -1, 0}, Rgb{1}, 1e-200);
  EXPECT_TRUE(tiny.is_delta());
  const auto s = tiny.sample_li({}, {0, 1, 0}, {0.5, 0.5});
  ASSERT_TRUE(s);
  EXPECT_TRUE(s->Li.is_finite());
  // NaN diameter: a delta direction.
  EXPECT_TRUE(DirectionalLight({0, -1, 0}, Rgb{1}, std::nan("")).is_delta());
}

}  // namespace
}  // namespace kiln::scene
