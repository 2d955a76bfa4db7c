// Several media as one (medium_sum.h, phase_mixture.h): transmittance through overlapping media is the product of
// each one's, the summed coefficients and absorption-weighted emission at a point, and the phase mixture where
// media of different g overlap is a density whose sample weights are unbiased per channel.
//
// Tolerance: each Monte Carlo mean within 4.5 of its own estimated standard errors (7e-6 per comparison for a normal
// estimate); quadratures as stated where they are.
#include "bakers/volume/medium_sum.h"

#include <gtest/gtest.h>

#include <cmath>

#include "bakers/math/constants.h"
#include "bakers/volume/homogeneous_medium.h"
#include "bakers/volume/phase_mixture.h"
#include "bakers/volume/tracking.h"
#include "tests/volume/media_test_util.h"

namespace kiln::volume {
namespace {

using test::estimate;

constexpr double kSigmas = 4.5;

HomogeneousMedium box_medium(const Rgb& sigma_a, const Rgb& sigma_s, const Rgb& Le, double g, const Bounds3& box) {
  return HomogeneousMedium({sigma_a, sigma_s, Le, g, box});
}

TEST(MediumSum, TransmittanceThroughOverlappingMediaIsTheProduct) {
  // Along +x from x = 0 to 4: box A covers [1, 3] and box B [2, 4].
  const HomogeneousMedium a = box_medium({0.5, 0.2, 0.1}, {0.1, 0.2, 0.3}, {}, 0, {{1, -1, -1}, {3, 1, 1}});
  const HomogeneousMedium b = box_medium({0.0, 0.3, 0.6}, {0.2, 0.2, 0.2}, {}, 0, {{2, -1, -1}, {4, 1, 1}});
  const MediumSum sum({&a, &b});
  const scene::Ray ray{{0, 0, 0}, {1, 0, 0}};
  const Rgb tau = (Rgb{0.5, 0.2, 0.1} + Rgb{0.1, 0.2, 0.3}) * 2.0 + (Rgb{0.0, 0.3, 0.6} + Rgb{0.2, 0.2, 0.2}) * 2.0;
  Pcg32 rng(11);
  for (auto* estimator : {&ratio_tracking_transmittance, &delta_tracking_transmittance}) {
    const auto e = estimate(40000, [&] { return estimator(sum, ray, 4.0, rng); });
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(e.mean[c], std::exp(-tau[c]), kSigmas * e.standard_error[c] + 1e-12) << "channel " << c;
  }
  // Outside both boxes the ray crosses nothing: no segment at all.
  EXPECT_FALSE(sum.majorants({{0, 5, 0}, {1, 0, 0}}, 4.0).next().has_value());
}

TEST(MediumSum, CoefficientsAddAndEmissionIsWeightedByAbsorption) {
  const HomogeneousMedium a = box_medium({1, 1, 0}, {0.5, 0, 0}, {2, 4, 6}, 0.3, {{-1, -1, -1}, {1, 1, 1}});
  const HomogeneousMedium b = box_medium({3, 0, 0}, {0, 0.5, 0}, {6, 8, 10}, -0.3, {{0, -1, -1}, {2, 1, 1}});
  const MediumSum sum({&a, &b});
  const MediumProperties both = sum.at({0.5, 0, 0});
  EXPECT_EQ(both.sigma_a.r, 4.0);
  EXPECT_EQ(both.sigma_s.g, 0.5);
  EXPECT_DOUBLE_EQ(both.Le.r, (1 * 2 + 3 * 6) / 4.0);  // Σ sigma_a Le / Σ sigma_a
  EXPECT_EQ(both.Le.g, 4.0);                           // only a absorbs green
  EXPECT_EQ(both.Le.b, 0.0);                           // nothing absorbs blue: it emits nothing
  EXPECT_EQ(sum.at({-0.5, 0, 0}).sigma_a.r, 1.0);      // a alone
  EXPECT_EQ(sum.bounds().hi.x, 2.0);
}

TEST(PhaseMixture, IsANormalisedDensityWithUnbiasedWeights) {
  PhaseMixture phase;
  phase.add(0.8, {1.0, 0.2, 0.0});
  phase.add(-0.4, {0.0, 0.5, 2.0});
  ASSERT_TRUE(phase.finish());
  const Vec3 wo = normalize(Vec3{0.3, -0.2, 1.0});
  // ∫ p dω = 1 per channel and ∫ pdf dω = 1, by the midpoint rule in (cos θ, φ) about wo. Both lobes are symmetric
  // about wo, so φ needs few steps; the g = 0.8 peak needs many in cos θ: the rule's error falls as the step squared,
  // 2.2e-4 at 1000 steps, so about 6e-7 at 20000 (the tolerance, 1e-5, is well above it).
  const Frame frame = Frame::from_normal(wo);
  Rgb p_integral;
  double pdf_integral = 0;
  constexpr int kMu = 20000, kPhi = 16;
  for (int i = 0; i < kMu; ++i) {
    const double mu = -1 + 2 * (i + 0.5) / kMu, s = std::sqrt(1 - mu * mu);
    for (int j = 0; j < kPhi; ++j) {
      const double phi = 2 * kPi * (j + 0.5) / kPhi;
      const Vec3 wi = frame.from_local({s * std::cos(phi), s * std::sin(phi), mu});
      p_integral += phase.p(wo, wi);
      pdf_integral += phase.pdf(wo, wi);
    }
  }
  const double dw = (2.0 / kMu) * (2 * kPi / kPhi);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(p_integral[c] * dw, 1.0, 1e-5) << "channel " << c;
  EXPECT_NEAR(pdf_integral * dw, 1.0, 1e-5);
  // E[weight] = ∫ p = 1 per channel; and the sampled pdf is the mixture's.
  Pcg32 rng(5);
  const auto e = estimate(100000, [&] {
    const PhaseMixture::Sample s = phase.sample(wo, rng.uniform(), {rng.uniform(), rng.uniform()});
    EXPECT_NEAR(s.pdf, phase.pdf(wo, s.wi), 1e-12 * (1 + s.pdf));
    return s.weight;
  });
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(e.mean[c], 1.0, kSigmas * e.standard_error[c]) << "channel " << c;
}

TEST(PhaseMixture, OneLobeIsThatLobe) {
  PhaseMixture phase;
  phase.add(0.5, {0.0, 0.0, 0.0});  // scatters nothing: left out
  phase.add(0.5, {0.2, 0.4, 0.0});
  ASSERT_TRUE(phase.finish());
  const HenyeyGreenstein hg(0.5);
  const Vec3 wo{0, 0, 1}, wi = normalize(Vec3{0.2, 0.1, -1});
  EXPECT_DOUBLE_EQ(phase.pdf(wo, wi), hg.pdf(wo, wi));
  EXPECT_DOUBLE_EQ(phase.p(wo, wi).r, hg.p(wo, wi));
  EXPECT_EQ(phase.p(wo, wi).b, 0.0);  // a channel nothing scatters
  const PhaseMixture::Sample s = phase.sample(wo, 0.3, {0.25, 0.75});
  EXPECT_EQ(s.weight.g, 1.0);
  PhaseMixture none;
  none.add(0.1, {});
  EXPECT_FALSE(none.finish());
}

}  // namespace
}  // namespace kiln::volume
