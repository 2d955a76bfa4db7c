#include "bakers/volume/henyey_greenstein.h"

#include <algorithm>
#include <cmath>

#include "bakers/math/constants.h"

namespace kiln::volume {

HenyeyGreenstein::HenyeyGreenstein(double g) : g_(std::isnan(g) ? 0.0 : std::clamp(g, -kMaxAsymmetry, kMaxAsymmetry)) {}

double HenyeyGreenstein::p(double mu) const {
  const double g = g_;
  // 1 + g² − 2gμ written as a sum of two non-negative terms, so the peak (μ → sign(g), |g| → 1) loses nothing to
  // cancellation: (1 − g)² + 2g(1 − μ) for g ≥ 0, (1 + g)² − 2g(1 + μ) for g < 0.
  const double denom = g >= 0 ? (1 - g) * (1 - g) + 2 * g * (1 - mu) : (1 + g) * (1 + g) - 2 * g * (1 + mu);
  return (1 - g) * (1 + g) * kInv4Pi / (denom * std::sqrt(denom));
}

// The textbook inverse, μ = (1 + g² − ((1 − g²)/(1 − g + 2gu))²) / (2g), divides by g and cancels catastrophically
// as g → 0 (pbrt-v4 switches to isotropic sampling below |g| = 1e-3, which no longer matches p). With a = 2u − 1 and
// d = 1 + g·a, multiplying out gives the same μ without the division:
//   μ = (a + g(a² + 3)/2 + g²a + g³(a² − 1)/2) / d²,
// exact at g = 0 (μ = a), and μ(u = 0) = −1, μ(u → 1) = 1 for every g. d ≥ 1 − |g| ≥ 1e-4 (kMaxAsymmetry).
double HenyeyGreenstein::sample_mu(double u) const {
  const double g = g_, a = 2 * u - 1, d = 1 + g * a;
  const double num = a + g * (a * a + 3) / 2 + g * g * a + g * g * g * (a * a - 1) / 2;
  // Rounding can push μ a few ulps past ±1, where sin θ = √(1 − μ²) would be NaN.
  return std::clamp(num / (d * d), -1.0, 1.0);
}

HenyeyGreenstein::Sample HenyeyGreenstein::sample(const Vec3& wo, Point2 u) const {
  const double mu = sample_mu(u.x);
  const double sin_theta = std::sqrt(std::max(0.0, 1 - mu * mu));
  const double phi = 2 * kPi * u.y;
  // The frame around the direction of travel −wo: its +z is μ = 1.
  const Frame frame = Frame::from_normal(-wo);
  const Vec3 wi = frame.from_local({sin_theta * std::cos(phi), sin_theta * std::sin(phi), mu});
  const double value = p(mu);
  return {wi, value, value};
}

}  // namespace kiln::volume
