// Chi-square goodness-of-fit test of a BRDF's sample() against its own pdf() (the approach of Mitsuba's chi2 test):
// the hemisphere is cut into (θ, φ) cells; N samples are drawn with Pcg32 and counted per cell; the expected count of
// each cell is N times the integral of pdf() over it, from a deterministic adaptive Gauss–Legendre rule. Failed
// samples form one more category whose expected count is N (1 − ∫ pdf). Cells expected to hold fewer than 5 samples
// are pooled (pearson_chi2 below: the χ² approximation of Pearson's statistic needs about 5 per category). The
// p-value comes from the regularised incomplete gamma function; the null hypothesis "sample() draws from pdf()" is
// rejected below a significance level Šidák-corrected for the number of tests run.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "bakers/brdf/bxdf.h"

namespace kiln::test {

// Regularised lower and upper incomplete gamma functions P(a, x) and Q(a, x) = 1 − P(a, x), a > 0, x ≥ 0: the power
// series where x < a + 1, Lentz's continued fraction otherwise; relative accuracy about 1e-14.
double gamma_p(double a, double x);
double gamma_q(double a, double x);
// Upper tail of the χ² distribution with dof degrees of freedom: Q(dof/2, statistic/2).
double chi2_p_value(double statistic, double dof);
// Šidák: the per-test level that makes the chance of any false rejection among `tests` independent tests = alpha.
double sidak_significance(double alpha, int tests);

// Pearson's statistic Σ (O − E)² / E of observed against expected counts, one pair per category (the same size).
// Categories expected to hold fewer than min_expected are pooled, smallest first, into one category, and the pool
// keeps taking the next smallest until it reaches min_expected itself (the χ² approximation of the statistic needs
// about 5 per category); a pool with nothing expected and nothing observed is dropped (no information, no degree of
// freedom). A category with nothing expected but something observed makes the statistic infinite. dof = categories
// − 1 and p is the χ² upper tail; with no degree of freedom p is 1 for a zero statistic, else 0.
struct PearsonResult {
  double statistic = 0;
  int dof = 0;
  double p_value = 0;
  // The `worst` categories contributing most to the statistic, one a line ("  contribution  name: observed o,
  // expected e"), for failure messages.
  std::string worst;
};
// `name` names category i in `worst` (default "category i"); the pool is "pooled categories".
PearsonResult pearson_chi2(const std::vector<double>& observed, const std::vector<double>& expected,
                           double min_expected = 5.0, int worst = 6,
                           const std::function<std::string(size_t)>& name = {});

struct Chi2Options {
  int n_theta = 64;  // cells in θ ∈ [0, π/2]
  int n_phi = 128;   // cells in φ ∈ [0, 2π)
  int64_t samples = 300000;
  uint64_t seed = 1;
  double significance = 0.01;  // family-wise level
  int test_count = 1;          // number of χ² tests in the family (Šidák correction)
  double min_expected = 5.0;   // pooling threshold
  // Per-cell integration tolerance of pdf() (relative, with an absolute floor in units of probability). The
  // statistic is insensitive to relative errors δ in expected counts (they add about N δ² in total), so 1e-4 is
  // ample; it also bounds the error of the reported pdf integral.
  double integration_rel_tol = 1e-4;
  double integration_abs_tol = 1e-10;
  // Kinks and jumps of pdf() (support edges, max/min) make cells along a curve refine to this depth; the error bound
  // still accounts for what is left.
  int integration_max_depth = 6;
  int worst_cells = 8;  // cells to print when the test fails
};

struct Chi2Result {
  bool passed = false;
  double statistic = 0;
  int dof = 0;
  double p_value = 0;
  double threshold = 0;           // the Šidák-corrected per-test significance
  double pdf_integral = 0;        // ∫ pdf over the hemisphere
  double pdf_integral_error = 0;  // bound on its quadrature error (sum of per-cell refinement differences)
  int64_t samples = 0;
  int64_t failures = 0;        // sample() returned nullopt
  int64_t invalid = 0;         // sample() succeeded with wi below the horizon, non-finite or not unit length
  double failed_fraction = 0;  // failures / samples
  int64_t pdf_evaluations = 0;
  bool integration_depth_limited = false;
  std::string details;  // statistic, p-value, and the worst cells (observed vs expected) when the test fails
};

Chi2Result chi2_test(const brdf::Bxdf& bxdf, const Vec3& wo, const Chi2Options& options = {});

}  // namespace kiln::test
