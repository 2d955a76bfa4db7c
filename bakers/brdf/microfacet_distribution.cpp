#include "bakers/brdf/microfacet_distribution.h"

#include <cmath>

#include "bakers/math/constants.h"

namespace kiln::brdf {

MicrofacetDistribution::MicrofacetDistribution(Distribution kind, double alpha_x, double alpha_y)
    : kind_(kind), alpha_x_(alpha_x), alpha_y_(alpha_y) {
  if (kind_ == Distribution::schlick_beckmann) alpha_x_ = alpha_y_ = std::sqrt(alpha_x * alpha_y);
}

double MicrofacetDistribution::D_beckmann(const Vec3& wh) const {
  // χ⁺: facets at or below the horizon do not exist (and cos⁴θ_h = 0 would divide by zero).
  if (!(wh.z > 0)) return 0.0;
  const double cos2 = wh.z * wh.z;
  // tan²θ_h (cos²φ/α_x² + sin²φ/α_y²), written with the components so that no azimuth is needed at the normal.
  const double e = ((wh.x / alpha_x_) * (wh.x / alpha_x_) + (wh.y / alpha_y_) * (wh.y / alpha_y_)) / cos2;
  // Far in the tail exp(-e) underflows while 1/cos⁴ may overflow: the product is 0 to double precision.
  if (e > 700.0) return 0.0;
  return std::exp(-e) / (kPi * alpha_x_ * alpha_y_ * cos2 * cos2);
}

double MicrofacetDistribution::D(const Vec3& wh) const {
  if (!(wh.z > 0)) return 0.0;  // χ⁺(wh·n)
  switch (kind_) {
    case Distribution::ggx: {
      // Walter et al. eq 33 multiplied through by cos⁴θ_h: 1 / (π α_x α_y ((x/α_x)² + (y/α_y)² + z²)²).
      // This form has no tan θ_h, so it stays finite at grazing facets and for α → 0.
      const double sx = wh.x / alpha_x_, sy = wh.y / alpha_y_;
      const double e = sx * sx + sy * sy + wh.z * wh.z;
      return 1.0 / (kPi * alpha_x_ * alpha_y_ * e * e);
    }
    case Distribution::beckmann:
      return D_beckmann(wh);
    case Distribution::schlick_beckmann: {
      // Schlick's rational Beckmann (survey eq 20) in t = n·h, m = α: D = m³x / (t (m x² − x² + m²)²), x = t + m − 1,
      // zero below t = 1 − m. Like the survey's eq 13 it approximates the Beckmann D WITHOUT 1/π, so it is divided by
      // π here. So divided it is exactly normalised: with y = x², ∫ D t dω = m³ ∫_0^{m²} dy / (m² − (1 − m) y)² = 1
      // (tests/brdf/microfacet_test.cpp checks it). Its tail is heavier than Beckmann's, though, and it has no Smith
      // Λ of its own: paired with Beckmann's Λ its visible normals integrate to more than 1 at grazing angles (an
      // energy gain that tests/brdf/microfacet_test.cpp measures).
      const double m = alpha_x_;
      const double t = wh.z;
      const double x = t + m - 1.0;
      if (x <= 0.0) return 0.0;  // outside the approximation's support [1 − m, 1]
      const double q = m * x * x - x * x + m * m;
      return m * m * m * x / (t * q * q) * kInvPi;
    }
  }
  return 0.0;
}

double MicrofacetDistribution::Lambda(const Vec3& w) const {
  const double cos2 = w.z * w.z;
  const double sin2 = std::fmax(0.0, 1.0 - cos2);
  // At the normal nothing is masked (tan θ = 0); a horizontal or NaN direction is handled by the callers, which never
  // ask for it (the contract returns zero before), but answer "fully masked" rather than divide by zero.
  if (sin2 == 0.0) return 0.0;
  if (!(cos2 > 0)) return INFINITY;
  // Projected roughness along the azimuth of w (Heitz 2014, eq 80): α² = cos²φ α_x² + sin²φ α_y².
  const double alpha2 = (w.x * w.x * alpha_x_ * alpha_x_ + w.y * w.y * alpha_y_ * alpha_y_) / sin2;
  const double tan2 = sin2 / cos2;
  if (kind_ == Distribution::ggx) {
    // Λ = (−1 + sqrt(1 + α² tan²θ)) / 2, Walter et al. eq 34 rearranged.
    return 0.5 * (std::sqrt(1.0 + alpha2 * tan2) - 1.0);
  }
  // Beckmann (Walter et al. eq 27, exact): a = 1 / (α tan θ), Λ = (erf(a) − 1)/2 + exp(−a²) / (2 a sqrt(π)).
  const double a = 1.0 / std::sqrt(alpha2 * tan2);
  // For large a both terms cancel to below double precision: Λ is 0 (erf(a) = 1 and exp(−a²) underflows past a ≈ 27).
  if (a > 26.0) return 0.0;
  // erf(a) − 1 written as −erfc(a), which keeps its relative precision where Λ is small.
  return -0.5 * std::erfc(a) + std::exp(-a * a) / (2.0 * a * std::sqrt(kPi));
}

double MicrofacetDistribution::D_visible(const Vec3& w, const Vec3& wh) const {
  if (!(w.z > 0)) return 0.0;
  const double w_dot_h = dot(w, wh);
  if (!(w_dot_h > 0)) return 0.0;  // back-facing microfacets are not visible from w
  return G1(w) * w_dot_h * D(wh) / w.z;
}

Vec3 MicrofacetDistribution::sample_wh(const Vec3& wo, Point2 u) const {
  if (kind_ == Distribution::ggx) {
    // Heitz 2018, "Sampling the GGX Distribution of Visible Normals": stretch wo to the configuration of a
    // hemisphere of unit roughness, sample the projected visible area there, and unstretch.
    const Vec3 vh = normalize(Vec3{alpha_x_ * wo.x, alpha_y_ * wo.y, wo.z});
    const double len2 = vh.x * vh.x + vh.y * vh.y;
    // wo along the normal: the orthonormal basis around vh is arbitrary; pick x.
    const Vec3 t1 = len2 > 0 ? Vec3{-vh.y, vh.x, 0.0} / std::sqrt(len2) : Vec3{1.0, 0.0, 0.0};
    const Vec3 t2 = cross(vh, t1);
    const double r = std::sqrt(u.x);
    const double phi = 2.0 * kPi * u.y;
    const double p1 = r * std::cos(phi);
    double p2 = r * std::sin(phi);
    const double s = 0.5 * (1.0 + vh.z);
    p2 = (1.0 - s) * std::sqrt(std::fmax(0.0, 1.0 - p1 * p1)) + s * p2;
    const Vec3 nh = t1 * p1 + t2 * p2 + vh * std::sqrt(std::fmax(0.0, 1.0 - p1 * p1 - p2 * p2));
    return normalize(Vec3{alpha_x_ * nh.x, alpha_y_ * nh.y, std::fmax(0.0, nh.z)});
  }
  if (kind_ == Distribution::schlick_beckmann) {
    // Inverting the CDF of D(t) t in x = t − (1 − m), measured from the lower end of the support:
    // P(x) = m³ / (1 − m) [1 / (m² − (1 − m) x²) − 1 / m²] = ξ  gives  x² = m² ξ / (m + ξ (1 − m)).
    // Sampling this D itself matters: its tail is heavier than Beckmann's, whose density would give estimates
    // of unbounded variance.
    const double m = alpha_x_;
    const double x = m * std::sqrt(u.x / (m + u.x * (1.0 - m)));
    const double cos_theta = std::fmin(1.0, x + 1.0 - m);
    const double sin_theta = std::sqrt(std::fmax(0.0, 1.0 - cos_theta * cos_theta));
    const double phi = 2.0 * kPi * u.y;
    return {sin_theta * std::cos(phi), sin_theta * std::sin(phi), cos_theta};
  }
  // Beckmann slopes are Gaussian: P22(x̃, ỹ) ∝ exp(−x̃²/α_x² − ỹ²/α_y²), sampled by Box–Muller; the normal of slope
  // (x̃, ỹ) is (−x̃, −ỹ, 1) normalised, and this samples D(wh) cos θ_h exactly.
  // u.x = 0 gives the radius 0 (the normal itself); 1 − u.x > 0 since u ∈ [0, 1).
  const double r = std::sqrt(-std::log1p(-u.x));
  const double phi = 2.0 * kPi * u.y;
  const Vec3 m{-alpha_x_ * r * std::cos(phi), -alpha_y_ * r * std::sin(phi), 1.0};
  return normalize(m);
}

double MicrofacetDistribution::pdf_wh(const Vec3& wo, const Vec3& wh) const {
  if (kind_ == Distribution::ggx) return D_visible(wo, wh);
  if (!(wh.z > 0)) return 0.0;
  if (kind_ == Distribution::schlick_beckmann) return D(wh) * wh.z;
  return D_beckmann(wh) * wh.z;
}

}  // namespace kiln::brdf
