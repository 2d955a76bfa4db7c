// Gauss–Legendre quadrature: deterministic integrals for tables, tests and reference values.
#pragma once

#include <vector>

namespace kiln {

struct QuadratureRule {
  std::vector<double> nodes;    // on [a, b]
  std::vector<double> weights;  // sum to (b - a)
};

// n-point Gauss–Legendre rule on [a, b]; nodes from Newton's iteration on P_n, accurate to double precision.
QuadratureRule gauss_legendre(int n, double a = -1.0, double b = 1.0);

// The same rule repeated on `panels` equal sub-intervals of [a, b] (composite rule).
QuadratureRule composite_gauss_legendre(int n, int panels, double a, double b);

}  // namespace kiln
