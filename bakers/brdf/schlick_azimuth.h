// The azimuthal factor of Schlick's distribution of normals, A_n(φ), with its exact sampling and a quadrature over φ
// that stays accurate however narrow its peaks (schlick_*.cpp only).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>

#include "bakers/brdf/schlick_internal.h"
#include "bakers/math/constants.h"

namespace kiln::brdf::detail {

// Below this p the peaks of A_n (width ~p) are integrated in a variable that flattens them; above it A_n varies at
// most by a factor 1/p ≤ 2 and smoothly, and plain Gauss–Legendre panels suffice.
constexpr double kPeakedIsotropy = 0.5;
constexpr int kAzimuthNodes = 8;   // Gauss nodes per azimuth panel (a quarter turn at most)
constexpr int kPeakEdgeNodes = 6;  // Gauss nodes in the outer pieces of a peak panel
constexpr int kPeakCoreNodes = 4;  // Gauss nodes in the flat core of a peak panel

// The normalised azimuthal factor A_n(φ) = AGM(1, p) / sqrt(cos²φ + p² sin²φ), a density A_n / (2π) over φ.
// Its CDF over a quarter turn is F(φ | m) / K(m), m = 1 − p² (incomplete / complete elliptic integrals of the first
// kind); it is sampled exactly by the Jacobi amplitude am(ξ K | m), computed by the AGM scale (Abramowitz & Stegun
// 16.4), whose ratios c_n / a_n depend on p only and are kept here.
class Azimuth {
 public:
  explicit Azimuth(double p);

  double p() const { return p_; }
  // The peak-panel variable of integrate(): tan(δ/2) = (p/2) sinh s.
  double s_of_delta(double delta) const { return std::asinh(2.0 * std::tan(0.5 * delta) / p_); }
  double agm() const { return agm_; }
  bool isotropic() const { return p_ == 1.0; }
  // A_n has peaks narrow enough to need their own treatment in integrate().
  bool peaked() const { return p_ < kPeakedIsotropy; }

  // A_n for a half vector with tangent-plane components (hx, hy).
  double factor(double hx, double hy) const {
    if (isotropic()) return 1.0;
    // hypot and the division keep (cos φ, sin φ) accurate even when hx, hy are tiny enough for their squares to
    // underflow.
    const double rho = std::hypot(hx, hy);
    // h along the normal: w is undefined (the limit depends on the direction of approach); this single direction
    // has measure zero, and the azimuthal mean 1 keeps D continuous in the mean.
    if (!(rho > 0)) return 1.0;
    return factor_of_angle(hx / rho, hy / rho);
  }
  double factor_of_angle(double c, double s) const {
    return isotropic() ? 1.0 : agm_ / std::sqrt(c * c + p_ * p_ * s * s);
  }

  // φ with density A_n(φ) / (2π) from ξ ∈ [0, 1), as (cos φ, sin φ). Each quarter turn holds probability 1/4; odd
  // quarters are mirrored so that every quarter starts where A_n is smallest (φ = 0 or π).
  void sample(double xi, double* cos_phi, double* sin_phi) const;

  // Calls node(cos φ, sin φ, weight) for quadrature nodes over [lo, hi] (hi − lo ≤ 2π) whose weights include the
  // density A_n / (2π): Σ weight g(φ) ≈ ∫_lo^hi g(φ) A_n(φ) / (2π) dφ. The interval is cut at π/4 + k π/2 into
  // quarter-turn panels centred on kπ/2. Where A_n is smooth (p ≥ kPeakedIsotropy, or panels centred on 0 and π,
  // where A_n varies by at most √2) the variable is φ. Panels centred on a peak (k odd) use s with
  // tan(δ/2) = (p/2) sinh s, δ = φ − kπ/2: s is δ/p at the peak and ln tan(δ/2) away from it, the two shapes of
  // A_n dδ, and A_n dδ = AGM cosh s / sqrt(sinh²s + (1 − τ²)²) ds with τ = tan(δ/2): within a few percent of AGM ds
  // at p = 1/2 and closer for smaller p, smooth and nearly flat whatever p. The shape of the integrand away from the
  // peak (|δ| ~ 1) lives in the last few units of s, so the s range is cut there into its own panels.
  template <class Node>
  void integrate(double lo, double hi, Node&& node) const {
    const QuadratureRule& rule = unit_rule(kAzimuthNodes);
    int k = static_cast<int>(std::floor((lo - kPiOver4) / kPiOver2)) + 1;  // panel [π/4 + (k−1)π/2, π/4 + kπ/2]
    double a = lo;
    while (a < hi) {
      const double b = std::min(hi, kPiOver4 + k * kPiOver2);
      const double centre = k * kPiOver2;
      const int km = ((k % 4) + 4) % 4;
      if (b > a) {
        if ((km & 1) && peaked()) {
          const double s0 = s_of_delta(a - centre), s1 = s_of_delta(b - centre);
          // Cuts at ±(s_edge − 4): inside them |δ| ≲ 2 tan(π/8) e^(−4) ≈ 0.015, where the integrand is flat.
          const double cut = std::max(0.0, s_edge_ - 4.0);
          double breaks[4] = {s0, std::clamp(-cut, s0, s1), std::clamp(cut, s0, s1), s1};
          for (int piece = 0; piece < 3; ++piece) {
            const double x0 = breaks[piece], x1 = breaks[piece + 1];
            if (!(x1 > x0)) continue;
            const QuadratureRule& pr = unit_rule(piece == 1 ? kPeakCoreNodes : kPeakEdgeNodes);
            for (size_t i = 0; i < pr.nodes.size(); ++i) {
              const double sv = x0 + (x1 - x0) * pr.nodes[i];
              const double ex = std::exp(sv), sh = 0.5 * (ex - 1.0 / ex), ch = 0.5 * (ex + 1.0 / ex);
              const double tau = 0.5 * p_ * sh, tau2 = tau * tau;
              const double sd = 2.0 * tau / (1.0 + tau2), cd = (1.0 - tau2) / (1.0 + tau2);
              const double w =
                  pr.weights[i] * (x1 - x0) * agm_ * kInv2Pi * ch / std::sqrt(sh * sh + (1.0 - tau2) * (1.0 - tau2));
              // φ = kπ/2 + δ for k ≡ 1 (π/2) or 3 (3π/2) mod 4.
              if (km == 1)
                node(-sd, cd, w);
              else
                node(sd, -cd, w);
            }
          }
        } else {
          for (size_t i = 0; i < rule.nodes.size(); ++i) {
            const double phi = a + (b - a) * rule.nodes[i];
            const double c = std::cos(phi), s = std::sin(phi);
            node(c, s, rule.weights[i] * (b - a) * kInv2Pi * factor_of_angle(c, s));
          }
        }
      }
      a = b;
      ++k;
    }
  }

 private:
  double p_;
  double agm_ = 1.0;
  double s_edge_ = 0.0;  // s at the edge of a peak panel, δ = π/4
  std::array<double, 24> ratio_{};
  int levels_ = 0;
};

}  // namespace kiln::brdf::detail
