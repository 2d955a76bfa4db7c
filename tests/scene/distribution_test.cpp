// Piecewise-constant 1-D and 2-D distributions: sampling against their own densities by χ², normalisation, and the
// guarded cases (zero cells, all-zero and non-finite tables).
#include "bakers/scene/distribution.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "tests/scene/light_test_util.h"

namespace kiln::scene {
namespace {

using test::pearson_chi2;

// Five χ² tests run in this file: the family-wise false-rejection rate is held at 1% by Šidák's correction.
const double kLevel = test::sidak_significance(0.01, 5);

TEST(Distribution1D, ContinuousSamplesFollowThePdf) {
  const std::vector<double> f = {0.5, 2.0, 0.0, 7.0, 1.0, 0.25, 3.0, 0.0};
  const Distribution1D d(f);
  // Integral of f over [0,1): the mean of the cells.
  EXPECT_DOUBLE_EQ(d.integral(), 13.75 / 8.0);
  // Histogram over 64 sub-bins (8 per cell), so that the within-cell linear inversion is tested too: expected counts
  // are N·pdf·width, exact for a piecewise-constant pdf.
  const int bins = 64;
  const int64_t n = 200000;
  std::vector<double> observed(bins, 0), expected(bins, 0);
  Pcg32 rng(3);
  for (int64_t k = 0; k < n; ++k) {
    const auto s = d.sample_continuous(rng.uniform());
    ASSERT_GE(s.x, 0.0);
    ASSERT_LT(s.x, 1.0);
    ASSERT_GT(s.pdf, 0.0) << "a sample in a cell of zero probability";
    // The reported density is the one pdf() gives at x, and the cell is x's.
    ASSERT_DOUBLE_EQ(s.pdf, d.pdf(s.x));
    ASSERT_EQ(s.cell, static_cast<int>(s.x * 8));
    observed[std::min(static_cast<int>(s.x * bins), bins - 1)] += 1;
  }
  double integral = 0;
  for (int b = 0; b < bins; ++b) {
    const double pdf = d.pdf((b + 0.5) / bins);
    expected[b] = n * pdf / bins;
    integral += pdf / bins;
  }
  // Exact sum of 64 dyadic-width terms: rounding only.
  EXPECT_NEAR(integral, 1.0, 1e-14);
  const auto r = pearson_chi2(observed, expected);
  EXPECT_GT(r.p_value, kLevel) << "chi2 " << r.statistic << " dof " << r.dof << "\n" << r.worst;
}

TEST(Distribution1D, GuardedInputsStayFinite) {
  // All zero: uniform, with integral 0 so that callers can tell.
  const Distribution1D zero(std::vector<double>(5, 0.0));
  EXPECT_TRUE(zero.uniform_fallback());
  EXPECT_EQ(zero.integral(), 0.0);
  EXPECT_DOUBLE_EQ(zero.pdf(0.7), 1.0);
  EXPECT_DOUBLE_EQ(zero.sample_continuous(0.5).pdf, 1.0);
  // Empty: one cell.
  const Distribution1D empty;
  EXPECT_EQ(empty.size(), 1);
  EXPECT_EQ(empty.sample_continuous(0.3).cell, 0);
  EXPECT_DOUBLE_EQ(empty.sample_continuous(0.3).pdf, 1.0);
  // NaN, ±Inf and negative entries are read as zero probability.
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  const Distribution1D bad({nan, 1.0, -inf, inf, -2.0, 1.0});
  EXPECT_FALSE(bad.uniform_fallback());
  // Cells 1 and 5 hold all of it, half each: density 0.5 · 6 cells = 3 there, 0 elsewhere.
  EXPECT_DOUBLE_EQ(bad.pdf(1.5 / 6), 3.0);
  EXPECT_EQ(bad.pdf(0.5 / 6), 0.0);
  EXPECT_EQ(bad.pdf(3.5 / 6), 0.0);
  for (double u : {0.0, 0.25, 0.5, 0.75, std::nextafter(1.0, 0.0), 1.0}) {
    const auto c = bad.sample_continuous(u);
    EXPECT_TRUE(c.cell == 1 || c.cell == 5) << u;
    EXPECT_TRUE(std::isfinite(c.pdf) && c.pdf > 0);
    EXPECT_LT(c.x, 1.0);
  }
  // Outside [0, 1] the density is 0.
  EXPECT_EQ(bad.pdf(-0.1), 0.0);
  EXPECT_EQ(bad.pdf(1.1), 0.0);
  EXPECT_EQ(bad.pdf(nan), 0.0);
}

TEST(Distribution2D, SamplesFollowThePdfWhichIntegratesToOne) {
  const int nu = 12, nv = 7;
  std::vector<double> f(nu * nv);
  Pcg32 gen(11);
  for (int v = 0; v < nv; ++v)
    for (int u = 0; u < nu; ++u) f[v * nu + u] = (u + v) % 5 == 0 ? 0.0 : gen.uniform() * (1 + u);
  // One whole row of zeros: its conditional is uniform but the marginal never picks it.
  for (int u = 0; u < nu; ++u) f[3 * nu + u] = 0;
  const Distribution2D d(f, nu, nv);
  double integral = 0;
  for (int v = 0; v < nv; ++v)
    for (int u = 0; u < nu; ++u) integral += d.pdf({(u + 0.5) / nu, (v + 0.5) / nv}) / (nu * nv);
  // The sum of nu·nv products of two normalised tables: rounding only.
  EXPECT_NEAR(integral, 1.0, 1e-13);
  // Histogram on a grid twice as fine as the cells in each direction.
  const int bu = 2 * nu, bv = 2 * nv;
  const int64_t n = 300000;
  std::vector<double> observed(bu * bv, 0), expected(bu * bv, 0);
  Pcg32 rng(13);
  for (int64_t k = 0; k < n; ++k) {
    const auto s = d.sample({rng.uniform(), rng.uniform()});
    ASSERT_GT(s.pdf, 0.0);
    ASSERT_NEAR(s.pdf, d.pdf(s.uv), 1e-12 * s.pdf);
    ASSERT_NE(s.iv, 3);
    observed[std::min(static_cast<int>(s.uv.y * bv), bv - 1) * bu + std::min(static_cast<int>(s.uv.x * bu), bu - 1)] +=
        1;
  }
  for (int v = 0; v < bv; ++v)
    for (int u = 0; u < bu; ++u) expected[v * bu + u] = n * d.pdf({(u + 0.5) / bu, (v + 0.5) / bv}) / (bu * bv);
  const auto r = pearson_chi2(observed, expected);
  EXPECT_GT(r.p_value, kLevel) << "chi2 " << r.statistic << " dof " << r.dof << "\n" << r.worst;
}

TEST(Distribution2D, AllZeroIsUniformAndBadShapesThrow) {
  const Distribution2D d(std::vector<double>(6, 0.0), 3, 2);
  EXPECT_TRUE(d.uniform_fallback());
  EXPECT_DOUBLE_EQ(d.pdf({0.2, 0.9}), 1.0);
  EXPECT_DOUBLE_EQ(d.sample({0.3, 0.6}).pdf, 1.0);
  EXPECT_THROW(Distribution2D(std::vector<double>(5, 1.0), 3, 2), std::invalid_argument);
  EXPECT_THROW(Distribution2D(std::vector<double>{}, 0, 0), std::invalid_argument);
}

}  // namespace
}  // namespace kiln::scene
