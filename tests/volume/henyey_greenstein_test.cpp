// The Henyey–Greenstein phase function: its sampling against its pdf (χ²), its normalisation and mean cosine, the
// division-free sampling map against the textbook one, and the guarded cases g → 0 and g → ±1.
#include "bakers/volume/henyey_greenstein.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "bakers/math/constants.h"
#include "bakers/math/quadrature.h"
#include "bakers/math/rng.h"
#include "tests/support/chi2.h"

namespace kiln::volume {
namespace {

const double kGs[] = {-0.9, 0.0, 0.5, 0.99};
// Four χ² tests run in this file: the family-wise false-rejection rate is held at 1% by Šidák's correction.
const double kLevel = test::sidak_significance(0.01, 4);

// θ edges (angle from the direction of travel −wo) on [0, π], dense at both ends where peaked lobes live: θ_i =
// π(1 − cos(π i/n))/2, so the first cell is 5e-4 rad wide for n = 120, narrower than the g = 0.99 lobe (~1e-2 rad).
std::vector<double> theta_edges(int n) {
  std::vector<double> e(n + 1);
  for (int i = 0; i <= n; ++i) e[i] = kPi * (1 - std::cos(kPi * i / n)) / 2;
  return e;
}

// ∫ p dμ over [a, b] by composite Gauss–Legendre (8 nodes × 8 panels per cell: the cells are narrow against p's
// scale of variation, so the rule is exact to ~1e-12 relative).
double integral_of_p(const HenyeyGreenstein& hg, double a, double b, double weight_mu = 0) {
  const QuadratureRule r = composite_gauss_legendre(8, 8, a, b);
  double s = 0;
  for (size_t i = 0; i < r.nodes.size(); ++i)
    s += r.weights[i] * hg.p(r.nodes[i]) * (weight_mu == 0 ? 1.0 : r.nodes[i]);
  return s;
}

TEST(HenyeyGreenstein, SamplesFollowThePdfChi2) {
  const int n_theta = 120, n_phi = 12;
  const int64_t n = 400000;
  const std::vector<double> edges = theta_edges(n_theta);
  const Vec3 wo = normalize(Vec3{0.3, -0.5, 0.8});
  const Frame frame = Frame::from_normal(-wo);
  for (double g : kGs) {
    const HenyeyGreenstein hg(g);
    std::vector<double> observed(n_theta * n_phi, 0.0), expected(n_theta * n_phi);
    for (int i = 0; i < n_theta; ++i)
      for (int j = 0; j < n_phi; ++j)
        expected[i * n_phi + j] = n * (2 * kPi / n_phi) * integral_of_p(hg, std::cos(edges[i + 1]), std::cos(edges[i]));
    Pcg32 rng(static_cast<uint64_t>(1000 * (g + 2)));
    for (int64_t s = 0; s < n; ++s) {
      const Vec3 l = frame.to_local(hg.sample(wo, {rng.uniform(), rng.uniform()}).wi);
      const double theta = std::acos(std::clamp(l.z, -1.0, 1.0));
      const double phi = std::atan2(l.y, l.x) + (l.y < 0 ? 2 * kPi : 0);
      const int i =
          std::clamp(int(std::upper_bound(edges.begin(), edges.end(), theta) - edges.begin()) - 1, 0, n_theta - 1);
      const int j = std::clamp(int(phi / (2 * kPi) * n_phi), 0, n_phi - 1);
      observed[i * n_phi + j] += 1;
    }
    const auto r = test::pearson_chi2(observed, expected);
    EXPECT_GT(r.p_value, kLevel) << "g " << g << " chi2 " << r.statistic << " dof " << r.dof << "\n" << r.worst;
  }
}

// ∫ p dω = 1 and the mean cosine ∫ μ p dω = g: the definition of HG's asymmetry. Quadrature over the same dense
// cells: 1e-9.
TEST(HenyeyGreenstein, NormalisedWithMeanCosineG) {
  const std::vector<double> edges = theta_edges(400);
  for (double g : {-0.99, -0.9, -0.3, 0.0, 0.2, 0.5, 0.9, 0.99}) {
    const HenyeyGreenstein hg(g);
    double total = 0, mean = 0;
    for (size_t i = 0; i + 1 < edges.size(); ++i) {
      total += 2 * kPi * integral_of_p(hg, std::cos(edges[i + 1]), std::cos(edges[i]));
      mean += 2 * kPi * integral_of_p(hg, std::cos(edges[i + 1]), std::cos(edges[i]), 1);
    }
    EXPECT_NEAR(total, 1.0, 1e-9) << "g " << g;
    EXPECT_NEAR(mean, g, 1e-9) << "g " << g;
  }
}

// The division-free map equals the textbook inverse μ = (1 + g² − ((1 − g²)/(1 − g + 2gu))²)/(2g) where the latter is
// well conditioned (|g| ≥ 0.1: its cancellation costs at most ~1e-14 there), and is 2u − 1 exactly at g = 0.
TEST(HenyeyGreenstein, SamplingMapMatchesTheTextbookInverse) {
  for (double g : {-0.95, -0.5, -0.1, 0.1, 0.5, 0.95}) {
    const HenyeyGreenstein hg(g);
    for (double u = 0; u < 1; u += 1.0 / 64) {
      const double s = (1 - g * g) / (1 - g + 2 * g * u);
      EXPECT_NEAR(hg.sample_mu(u), (1 + g * g - s * s) / (2 * g), 1e-13) << "g " << g << " u " << u;
    }
  }
  const HenyeyGreenstein iso(0.0);
  for (double u = 0; u < 1; u += 1.0 / 64) EXPECT_EQ(iso.sample_mu(u), 2 * u - 1);
}

// g → ±1 (a Dirac delta at the limit), tiny |g| and NaN: finite, positive densities and unit directions; the sampled
// pdf equals pdf() for the returned direction.
TEST(HenyeyGreenstein, LimitsStayFinite) {
  const Vec3 wo = normalize(Vec3{0.1, 0.2, -0.97});
  for (double g : {-1.0, -1.0 + 1e-12, -0.9999, -1e-300, 0.0, 1e-12, 0.9999, 1.0 - 1e-12, 1.0, double(NAN)}) {
    const HenyeyGreenstein hg(g);
    EXPECT_LE(std::fabs(hg.g()), HenyeyGreenstein::kMaxAsymmetry);
    Pcg32 rng(4);
    for (int i = 0; i < 2000; ++i) {
      const auto s = hg.sample(wo, {rng.uniform(), rng.uniform()});
      ASSERT_TRUE(is_finite(s.wi) && std::isfinite(s.pdf) && s.pdf > 0) << "g " << g;
      EXPECT_NEAR(length(s.wi), 1.0, 1e-12);
      // Near the peak p changes by ~1e-4 relative per 1e-16 of μ at |g| = 0.9999; away from it far less.
      EXPECT_NEAR(hg.pdf(wo, s.wi), s.pdf, 1e-3 * s.pdf) << "g " << g;
    }
    EXPECT_TRUE(std::isfinite(hg.p(1.0)) && std::isfinite(hg.p(-1.0)));
  }
}

}  // namespace
}  // namespace kiln::volume
