#include "tests/support/chi2.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "bakers/math/constants.h"
#include "bakers/math/rng.h"
#include "tests/support/hemisphere.h"

namespace kiln::test {

namespace {

constexpr double kEps = 1e-15;
constexpr int kMaxIterations = 100000;  // the series and fraction need O(sqrt(a)) terms; dof here is ≤ ~1e5

// log of the common prefactor x^a e^−x / Γ(a).
double log_prefactor(double a, double x) { return a * std::log(x) - x - std::lgamma(a); }

// P(a, x) = x^a e^−x / Γ(a) · Σ_n x^n / (a (a+1) ... (a+n)): converges fast for x < a + 1.
double gamma_p_series(double a, double x) {
  double term = 1.0 / a, sum = term;
  for (int n = 1; n < kMaxIterations; ++n) {
    term *= x / (a + n);
    sum += term;
    if (std::fabs(term) < std::fabs(sum) * kEps) break;
  }
  return std::exp(log_prefactor(a, x)) * sum;
}

// Q(a, x) = x^a e^−x / Γ(a) · 1 / (x + 1 − a − 1·(1 − a) / (x + 3 − a − 2·(2 − a) / (x + 5 − a − ...))),
// evaluated with the modified Lentz method: converges fast for x > a + 1.
double gamma_q_fraction(double a, double x) {
  constexpr double tiny = 1e-300;
  double b = x + 1.0 - a;
  double c = 1.0 / tiny;
  double d = 1.0 / b;
  double h = d;
  for (int i = 1; i < kMaxIterations; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::fabs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::fabs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::fabs(delta - 1.0) < kEps) break;
  }
  return std::exp(log_prefactor(a, x)) * h;
}

// Cell index (θ index · n_phi + φ index) as a range of angles, for failure messages.
std::string describe_cell(size_t index, const Chi2Options& o) {
  char buf[120];
  const int it = static_cast<int>(index) / o.n_phi, ip = static_cast<int>(index) % o.n_phi;
  const double dt = 90.0 / o.n_theta, dp = 360.0 / o.n_phi;
  std::snprintf(buf, sizeof buf, "theta [%.2f, %.2f] deg, phi [%.2f, %.2f] deg", it * dt, (it + 1) * dt, ip * dp,
                (ip + 1) * dp);
  return buf;
}

}  // namespace

double gamma_p(double a, double x) {
  if (!(a > 0) || !(x >= 0)) return std::numeric_limits<double>::quiet_NaN();
  if (x == 0) return 0.0;
  if (std::isinf(x)) return 1.0;
  return x < a + 1.0 ? gamma_p_series(a, x) : 1.0 - gamma_q_fraction(a, x);
}

double gamma_q(double a, double x) {
  if (!(a > 0) || !(x >= 0)) return std::numeric_limits<double>::quiet_NaN();
  if (x == 0) return 1.0;
  if (std::isinf(x)) return 0.0;
  return x < a + 1.0 ? 1.0 - gamma_p_series(a, x) : gamma_q_fraction(a, x);
}

double chi2_p_value(double statistic, double dof) { return gamma_q(0.5 * dof, 0.5 * statistic); }

double sidak_significance(double alpha, int tests) {
  // 1 − (1 − α)^(1/m), computed without cancellation for small α.
  return -std::expm1(std::log1p(-alpha) / std::max(tests, 1));
}

PearsonResult pearson_chi2(const std::vector<double>& observed, const std::vector<double>& expected,
                           double min_expected, int worst, const std::function<std::string(size_t)>& name) {
  if (observed.size() != expected.size()) {
    throw std::invalid_argument("pearson_chi2: " + std::to_string(observed.size()) + " observed counts but " +
                                std::to_string(expected.size()) + " expected; give one of each per category");
  }
  constexpr size_t kPool = SIZE_MAX;
  struct Category {
    size_t index;  // into the input, or kPool
    double expected, observed;
  };
  std::vector<Category> cells;
  cells.reserve(observed.size());
  for (size_t i = 0; i < observed.size(); ++i) cells.push_back({i, expected[i], observed[i]});
  // Pool the categories expected to hold fewer than min_expected, smallest first; if the pool itself stays below the
  // threshold, keep adding the next smallest.
  std::sort(cells.begin(), cells.end(), [](const Category& a, const Category& b) { return a.expected < b.expected; });
  Category pool{kPool, 0, 0};
  size_t first = 0;
  const auto pooled = [&](size_t i) {
    return cells[i].expected < min_expected || (i > 0 && pool.expected < min_expected);
  };
  while (first < cells.size() && pooled(first)) {
    pool.expected += cells[first].expected;
    pool.observed += cells[first].observed;
    ++first;
  }
  std::vector<Category> categories(cells.begin() + static_cast<std::ptrdiff_t>(first), cells.end());
  // A pool with nothing expected and nothing observed carries no information (and no degree of freedom).
  if (pool.expected > 0 || pool.observed > 0) categories.push_back(pool);

  PearsonResult r;
  std::vector<double> contribution(categories.size());
  for (size_t k = 0; k < categories.size(); ++k) {
    const Category& c = categories[k];
    const double d = c.observed - c.expected;
    // A category with nothing expected and something observed cannot come from the expected distribution.
    contribution[k] = c.expected > 0 ? d * d / c.expected : (c.observed > 0 ? HUGE_VAL : 0.0);
    r.statistic += contribution[k];
  }
  r.dof = static_cast<int>(categories.size()) - 1;
  r.p_value = r.dof > 0 ? chi2_p_value(r.statistic, r.dof) : (r.statistic == 0 ? 1.0 : 0.0);

  std::vector<size_t> order(categories.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return contribution[a] > contribution[b]; });
  std::ostringstream out;
  for (size_t k = 0; k < std::min(order.size(), static_cast<size_t>(std::max(worst, 0))); ++k) {
    const Category& c = categories[order[k]];
    const std::string what = c.index == kPool ? "pooled categories"
                             : name           ? name(c.index)
                                              : "category " + std::to_string(c.index);
    out << "  " << contribution[order[k]] << "  " << what << ": observed " << c.observed << ", expected " << c.expected
        << "\n";
  }
  r.worst = out.str();
  return r;
}

Chi2Result chi2_test(const brdf::Bxdf& bxdf, const Vec3& wo, const Chi2Options& o) {
  Chi2Result res;
  res.samples = o.samples;
  res.threshold = sidak_significance(o.significance, o.test_count);
  const int n_cells = o.n_theta * o.n_phi;
  const double dtheta = kPiOver2 / o.n_theta, dphi = 2.0 * kPi / o.n_phi;

  // Observed counts.
  std::vector<double> observed(n_cells, 0.0);
  Pcg32 rng(o.seed, 0x9e3779b97f4a7c15ULL ^ o.seed);
  for (int64_t k = 0; k < o.samples; ++k) {
    const Point2 u{rng.uniform(), rng.uniform()};
    const double uc = rng.uniform();
    const auto s = bxdf.sample(wo, u, uc);
    if (!s) {
      ++res.failures;
      continue;
    }
    const Vec3& wi = s->wi;
    if (!(wi.z > 0) || !is_finite(wi) || std::fabs(length(wi) - 1.0) > 1e-9) {
      ++res.invalid;
      continue;
    }
    const int it = std::min(static_cast<int>(spherical_theta(wi) / dtheta), o.n_theta - 1);
    const int ip = std::min(static_cast<int>(spherical_phi(wi) / dphi), o.n_phi - 1);
    observed[it * o.n_phi + ip] += 1.0;
  }
  res.failed_fraction = static_cast<double>(res.failures) / static_cast<double>(o.samples);

  // Expected counts; failed samples are one more category (index n_cells).
  std::vector<double> expected(n_cells + 1, 0.0);
  observed.push_back(static_cast<double>(res.failures));
  const DirectionFunction pdf = [&](const Vec3& wi) { return bxdf.pdf(wo, wi); };
  for (int it = 0; it < o.n_theta; ++it) {
    for (int ip = 0; ip < o.n_phi; ++ip) {
      const CellIntegral ci = integrate_cell(pdf, it * dtheta, (it + 1) * dtheta, ip * dphi, (ip + 1) * dphi,
                                             o.integration_rel_tol, o.integration_abs_tol, 2, o.integration_max_depth);
      expected[it * o.n_phi + ip] = ci.value * static_cast<double>(o.samples);
      res.pdf_integral += ci.value;
      res.pdf_integral_error += ci.error;
      res.pdf_evaluations += ci.evaluations;
      res.integration_depth_limited = res.integration_depth_limited || ci.depth_limited;
    }
  }
  // The failed samples' expectation is clamped at 0 when ∫ pdf > 1 (which fails separately).
  expected[n_cells] = std::max(0.0, 1.0 - res.pdf_integral) * static_cast<double>(o.samples);

  const PearsonResult p = pearson_chi2(observed, expected, o.min_expected, o.worst_cells, [&](size_t i) {
    return i == static_cast<size_t>(n_cells) ? std::string("failed samples") : describe_cell(i, o);
  });
  res.statistic = p.statistic;
  res.dof = p.dof;
  res.p_value = p.p_value;
  res.passed = res.p_value > res.threshold && res.invalid == 0;

  std::ostringstream out;
  out << bxdf.describe() << " at wo = (" << wo.x << ", " << wo.y << ", " << wo.z << "): chi2 = " << res.statistic
      << ", dof = " << res.dof << ", p = " << res.p_value << " (reject below " << res.threshold << "), pdf integral "
      << res.pdf_integral << " +- " << res.pdf_integral_error << ", failed samples " << res.failures << " / "
      << res.samples << ", invalid samples " << res.invalid << "\n";
  if (!res.passed) out << "worst categories (contribution to chi2):\n" << p.worst;
  res.details = out.str();
  return res;
}

}  // namespace kiln::test
