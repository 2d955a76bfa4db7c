#include "bakers/math/quadrature.h"

#include <cmath>
#include <stdexcept>

#include "bakers/math/constants.h"

namespace kiln {

QuadratureRule gauss_legendre(int n, double a, double b) {
  if (n < 1) throw std::invalid_argument("gauss_legendre: the number of nodes must be at least 1");
  QuadratureRule rule;
  rule.nodes.resize(n);
  rule.weights.resize(n);
  const double half = 0.5 * (b - a), mid = 0.5 * (a + b);
  for (int i = 0; i < (n + 1) / 2; ++i) {
    // Tricomi's initial guess for the i-th root, then Newton on the three-term recurrence.
    double x = std::cos(kPi * (i + 0.75) / (n + 0.5));
    double dp = 1.0;
    for (int iter = 0; iter < 100; ++iter) {
      double p0 = 1.0, p1 = x;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      if (n == 1) p0 = 1.0, p1 = x;
      dp = n * (x * p1 - p0) / (x * x - 1.0);
      const double dx = p1 / dp;
      x -= dx;
      if (std::fabs(dx) < 1e-16) break;
    }
    // Recompute the derivative at the converged root for the weight.
    {
      double p0 = 1.0, p1 = x;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      dp = n * (x * p1 - p0) / (x * x - 1.0);
    }
    const double w = 2.0 / ((1.0 - x * x) * dp * dp);
    rule.nodes[i] = mid - half * x;
    rule.nodes[n - 1 - i] = mid + half * x;
    rule.weights[i] = rule.weights[n - 1 - i] = w * half;
  }
  return rule;
}

QuadratureRule composite_gauss_legendre(int n, int panels, double a, double b) {
  if (panels < 1) throw std::invalid_argument("composite_gauss_legendre: at least one panel is needed");
  QuadratureRule out;
  const double h = (b - a) / panels;
  for (int p = 0; p < panels; ++p) {
    const QuadratureRule r = gauss_legendre(n, a + p * h, a + (p + 1) * h);
    out.nodes.insert(out.nodes.end(), r.nodes.begin(), r.nodes.end());
    out.weights.insert(out.weights.end(), r.weights.begin(), r.weights.end());
  }
  return out;
}

}  // namespace kiln
