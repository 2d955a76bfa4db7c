// The environment lobes: names, distributions, and the normalisation W = ∫ D(h)(n·l) dω_l against an independent
// quadrature in the angle of l.
#include "bakers/envmap/lobe.h"

#include <gtest/gtest.h>

#include <cmath>

#include "bakers/brdf/microfacet_distribution.h"
#include "bakers/math/constants.h"
#include "bakers/math/quadrature.h"
#include "bakers/math/vec3.h"

namespace kiln::envmap {
namespace {

TEST(Lobe, NamesRoundTripAndMapToTheirDistributions) {
  for (EnvLobe l : {EnvLobe::ggx, EnvLobe::beckmann, EnvLobe::cook_torrance, EnvLobe::schlick})
    EXPECT_EQ(env_lobe_from_string(to_string(l)), l);
  EXPECT_FALSE(env_lobe_from_string("phong"));
  EXPECT_EQ(lobe_distribution(EnvLobe::ggx), brdf::Distribution::ggx);
  EXPECT_EQ(lobe_distribution(EnvLobe::beckmann), brdf::Distribution::beckmann);
  // Cook–Torrance's D is Beckmann's, as bakers/brdf's Model::cook_torrance uses by default.
  EXPECT_EQ(lobe_distribution(EnvLobe::cook_torrance), brdf::Distribution::beckmann);
  EXPECT_EQ(lobe_model(EnvLobe::cook_torrance).model, brdf::Model::cook_torrance);
  EXPECT_EQ(lobe_distribution(EnvLobe::schlick), brdf::Distribution::schlick_beckmann);
  EXPECT_EQ(lobe_model(EnvLobe::schlick).distribution, brdf::Distribution::schlick_beckmann);
}

// With n = v, h bisects n and l: θ_h = θ_l / 2, so W = 2π ∫_0^{π/2} D(θ_l/2) cos θ_l sin θ_l dθ_l, integrated here
// on 4000 Gauss panels in θ_l (panel width 4e-4 rad, 1/25 of the narrowest lobe's width 2α = 0.02 rad): the
// quadrature error is far below the 1e-9 relative tolerance (the two computations share only D).
TEST(Lobe, NormalizationMatchesDirectQuadrature) {
  const QuadratureRule rule = composite_gauss_legendre(8, 4000, 0.0, kPiOver2);
  for (auto d : {brdf::Distribution::ggx, brdf::Distribution::beckmann, brdf::Distribution::schlick_beckmann}) {
    for (double alpha : {0.01, 0.05, 0.2, 0.5, 1.0}) {
      const brdf::MicrofacetDistribution dist(d, alpha, alpha);
      double direct = 0.0;
      for (size_t i = 0; i < rule.nodes.size(); ++i) {
        const double tl = rule.nodes[i], th = 0.5 * tl;
        direct += rule.weights[i] * dist.D({std::sin(th), 0.0, std::cos(th)}) * std::cos(tl) * std::sin(tl);
      }
      direct *= 2.0 * kPi;
      EXPECT_NEAR(lobe_normalization(d, alpha), direct, 1e-9 * direct) << brdf::to_string(d) << " alpha " << alpha;
    }
  }
  // GGX at α = 1 has D = 1/π everywhere on the hemisphere of h: W = ∫ cos θ_l / π dω_l = 1 exactly (1e-12: rounding).
  EXPECT_NEAR(lobe_normalization(brdf::Distribution::ggx, 1.0), 1.0, 1e-12);
  // α → 0: p(l) = D/4 is a normalised density concentrated at l = n, where n·l = 1, so W → 4 (at α = 0.001 the
  // lobe's mean n·l is 1 − O(α²)·few: 1e-5).
  EXPECT_NEAR(lobe_normalization(brdf::Distribution::beckmann, 1e-3), 4.0, 4e-5);
}

TEST(Lobe, WeightIsZeroBelowTheHorizonAndSymmetricAboutN) {
  const SplitSumLobe lobe(brdf::Distribution::ggx, 0.3);
  const Vec3 n = normalize(Vec3{0.2, 0.9, -0.3});
  EXPECT_EQ(lobe.weight(n, -n), 0.0);  // l = −n: h undefined, below the horizon
  EXPECT_GT(lobe.weight(n, n), 0.0);
  // D(h)(n·l) at l = n equals D at the normal: 1/(π α²) for GGX (1e-12 relative: rounding).
  EXPECT_NEAR(lobe.weight(n, n), 1.0 / (kPi * 0.09), 1e-12 / (kPi * 0.09));
}

// GGX's weight is computed in closed form from n·l alone (the brute-force references' inner loop); it must be the
// library's D(h)(n·l) with h = normalize(n + l), to rounding: 1e-12 relative over widths and angles down to grazing.
TEST(Lobe, GgxWeightInClosedFormIsDOfTheHalfVectorTimesNl) {
  for (double alpha : {1.0 / 36, 0.1, 0.5, 1.0}) {
    const SplitSumLobe lobe(brdf::Distribution::ggx, alpha);
    const brdf::MicrofacetDistribution d(brdf::Distribution::ggx, alpha, alpha);
    const Vec3 n = normalize(Vec3{0.3, -0.5, 0.8});
    for (double theta : {0.0, 1e-4, 0.01, 0.3, 1.0, 1.5, 1.5707}) {
      for (double phi : {0.0, 1.0, 4.0}) {
        const Frame frame = Frame::from_normal(n);
        const Vec3 l =
            frame.from_local({std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)});
        const Vec3 h = normalize(n + l);
        const double nh = dot(n, h);
        const double expected = d.D({std::sqrt(std::fmax(0.0, 1.0 - nh * nh)), 0.0, nh}) * dot(n, l);
        EXPECT_NEAR(lobe.weight(n, l), expected, 1e-12 * expected) << alpha << " " << theta << " " << phi;
      }
    }
  }
}

}  // namespace
}  // namespace kiln::envmap
