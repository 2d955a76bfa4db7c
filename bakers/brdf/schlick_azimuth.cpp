#include "bakers/brdf/schlick_azimuth.h"

namespace kiln::brdf::detail {

Azimuth::Azimuth(double p) : p_(p) {
  double a = 1.0, b = p, c = std::sqrt((1.0 - p) * (1.0 + p));
  // Quadratic convergence: c_n / a_n falls below 1e-17 in at most ~7 steps for p ≥ kMinIsotropy.
  while (c > 1e-17 * a && levels_ + 1 < static_cast<int>(ratio_.size())) {
    const double an = 0.5 * (a + b), bn = std::sqrt(a * b), cn = 0.5 * (a - b);
    a = an, b = bn, c = cn;
    ratio_[++levels_] = c / a;
  }
  agm_ = a;
  s_edge_ = s_of_delta(kPiOver4);
}

void Azimuth::sample(double xi, double* cos_phi, double* sin_phi) const {
  const double q4 = 4.0 * xi;
  const int quarter = std::min(3, std::max(0, static_cast<int>(q4)));
  const double f = q4 - quarter;  // fraction of the quarter's probability
  // am(f K | m): φ_N = 2^N a_N f K = 2^(N−1) π f, then back through φ_(n−1) = (φ_n + asin(c_n/a_n sin φ_n)) / 2.
  double psi = std::ldexp(kPi * f, levels_ - 1);
  for (int n = levels_; n >= 1; --n) psi = 0.5 * (psi + std::asin(ratio_[n] * std::sin(psi)));
  const double c = std::cos(psi), s = std::sin(psi);
  switch (quarter) {
    case 0:
      *cos_phi = c, *sin_phi = s;
      break;  // φ = ψ
    case 1:
      *cos_phi = -c, *sin_phi = s;
      break;  // φ = π − ψ
    case 2:
      *cos_phi = -c, *sin_phi = -s;
      break;  // φ = π + ψ
    default:
      *cos_phi = c, *sin_phi = -s;
      break;  // φ = 2π − ψ
  }
}

}  // namespace kiln::brdf::detail
