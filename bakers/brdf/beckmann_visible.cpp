#include "bakers/brdf/beckmann_visible.h"

#include <algorithm>
#include <cfloat>
#include <cmath>

#include "bakers/math/constants.h"

namespace kiln::brdf {
namespace {

constexpr double kInvSqrtPi = 0.56418958354775628695;  // 1/√π

// erfc⁻¹(q) for q ∈ (0, 1]: x ≥ 0. Newton's method on log erfc(x) − log q, which is close to linear in x² for large
// x (erfc(x) ≈ e^{−x²}/(x√π)), so a handful of steps from the asymptotic guess reach double precision even for q
// near DBL_MIN, where Newton on erfc itself would crawl.
double erfc_inverse_upper(double q) {
  if (q >= 1.0) return 0.0;
  const double log_q = std::log(q);
  // Initial guess: for small q, x² ≈ −log(q) − log(x√π); for q near 1, erfc(x) ≈ 1 − 2x/√π.
  double x = q > 0.5 ? (1.0 - q) * 0.5 / kInvSqrtPi : std::sqrt(std::fmax(0.0, -log_q - std::log(std::sqrt(-log_q))));
  for (int it = 0; it < 50; ++it) {
    const double ec = std::erfc(x);
    // (log erfc)' = −2 e^{−x²} / (√π erfc(x)).
    const double slope = -2.0 * kInvSqrtPi * std::exp(-x * x) / ec;
    const double step = (std::log(ec) - log_q) / slope;
    x = std::fmax(0.0, x - step);
    if (std::fabs(step) <= 1e-15 * std::fmax(1.0, x)) break;
  }
  return x;
}

}  // namespace

double erfc_inverse(double q) {
  // erfc(−x) = 2 − erfc(x): the lower half mirrors the upper one, and 2 − q keeps its precision for q ≥ 1.
  return q <= 1.0 ? erfc_inverse_upper(q) : -erfc_inverse_upper(2.0 - q);
}

Point2 sample_beckmann_visible_slope(double cos_theta, Point2 u) {
  // The extremes of [0, 1) map to slopes of ±∞ (facets on the horizon): keep u where erfc⁻¹ is finite. The slopes
  // reached, |ỹ| ≈ 26.5, are beyond any facet the distribution puts measurable weight on (e^{−700}).
  const double uy = std::clamp(u.y, DBL_MIN, 1.0 - DBL_EPSILON / 2);
  // ỹ has density e^{−ỹ²}/√π: its CDF is erfc(−ỹ)/2 = u.y, computed from whichever end keeps the precision.
  const double slope_y = uy < 0.5 ? -erfc_inverse(2.0 * uy) : erfc_inverse(2.0 * (1.0 - uy));

  const double ux = std::clamp(u.x, DBL_MIN, 1.0 - DBL_EPSILON / 2);
  const double sin_theta = std::sqrt(std::fmax(0.0, 1.0 - cos_theta * cos_theta));
  // x̃ has density ∝ (1 − x̃ tan θ) e^{−x̃²} on (−∞, cot θ]. Its CDF, with t = tan θ, is
  //   C(x̃) = [erfc(−x̃) + t e^{−x̃²}/√π] / Z,  Z = erfc(−cot θ) + t e^{−cot²θ}/√π   (Heitz & d'Eon 2014, eq 11),
  // written with erfc(−x̃) = 1 + erf(x̃), which keeps its relative precision far in the left tail.
  if (sin_theta == 0.0) return {-erfc_inverse(2.0 * ux), slope_y};  // seen from the normal: no facet is hidden
  const double t = sin_theta / cos_theta;
  const double cot = cos_theta / sin_theta;
  const double z = std::erfc(-cot) + t * std::exp(-cot * cot) * kInvSqrtPi;
  const double target = ux * z;
  const auto cdf = [&](double x) { return std::erfc(-x) + t * std::exp(-x * x) * kInvSqrtPi; };
  // Safeguarded Newton on C(x̃) Z − u Z over the bracket [lo, cot θ]: C is increasing there (its density is ≥ 0),
  // so the bracket shrinks with every evaluation and a step leaving it is replaced by bisection. C(−27) is 0 to
  // double precision for any t (t e^{−729} underflows for t ≤ 1e100, the steepest the horizon guard allows).
  double lo = -27.0, hi = cot;
  // Start from the Gaussian quantile, where the visible weighting barely matters (near the normal), clamped in.
  double x = std::clamp(-erfc_inverse(2.0 * ux), lo, hi);
  for (int it = 0; it < 100; ++it) {
    const double f = cdf(x) - target;
    // Converged when C(x̃) is within a few ulps of u: what matters is the probability, not x̃ itself (near cot θ the
    // density vanishes and x̃ is ill-conditioned in u, but any x̃ there has the right probability).
    if (std::fabs(f) <= 4.0 * DBL_EPSILON * z) break;
    (f < 0.0 ? lo : hi) = x;
    const double density = 2.0 * kInvSqrtPi * std::exp(-x * x) * (1.0 - x * t);
    double next = density > 0.0 ? x - f / density : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    // Or stop when the step, or the bracket, has shrunk to the rounding of x̃ itself.
    if (std::fabs(next - x) <= 1e-15 * std::fmax(1.0, std::fabs(x)) ||
        hi - lo <= 1e-15 * std::fmax(1.0, std::fabs(x))) {
      x = next;
      break;
    }
    x = next;
  }
  return {x, slope_y};
}

}  // namespace kiln::brdf
