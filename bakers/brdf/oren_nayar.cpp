// Oren & Nayar, "Generalization of Lambert's reflectance model", SIGGRAPH 1994 (and IJCV 1995).
//
// The surface is made of V-cavities whose facets are Lambertian, with facet slopes Gaussian of standard deviation σ.
// With θ the polar angle, α = max(θ_i, θ_o), β = min(θ_i, θ_o) and Δφ = φ_o − φ_i, the first-order (single bounce)
// radiance, divided by the irradiance E0 cos θ_i, is the BRDF
//   f1 = ρ/π [C1 + cos Δφ C2 tan β + (1 − |cos Δφ|) C3 tan((α + β)/2)]
//   C1 = 1 − 0.5 σ²/(σ² + 0.33)
//   C2 = 0.45 σ²/(σ² + 0.09) sin α                      if cos Δφ ≥ 0
//        0.45 σ²/(σ² + 0.09) (sin α − (2β/π)³)         otherwise
//   C3 = 0.125 σ²/(σ² + 0.09) (4αβ/π²)²
// and the two-bounce interreflection term is
//   f2 = 0.17 ρ²/π σ²/(σ² + 0.13) [1 − cos Δφ (2β/π)²].
// The survey's eq 26 closes the bracket after cos Δφ, which would add cos Δφ to C1 and leave the C2 and C3 terms
// outside the ρ/π factor; the form above is the paper's (and what Mitsuba's roughdiffuse implements).
// The simplified model (the paper's "qualitative model", survey eq 27) keeps only the C1 and positive-cos Δφ C2 parts:
//   f = ρ/π (A + B max(0, cos Δφ) sin α tan β), A = C1, B = 0.45 σ²/(σ² + 0.09).
//
// Everything is evaluated from the components of the directions rather than from angles taken with acos, so that
// tan β near the horizon and sin β near the normal keep their relative precision. Every quantity is computed
// symmetrically in (wo, wi), so reciprocity holds to the last bit.
#include "bakers/brdf/oren_nayar.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "bakers/bake/number_format.h"
#include "bakers/math/constants.h"

namespace kiln::brdf {
namespace {

constexpr double kMaxFinite = std::numeric_limits<double>::max();

// σ²/(σ² + k), the saturating roughness factor every coefficient of the model uses.
double roughness_ratio(double sigma, double k) {
  const double sigma2 = sigma * sigma;
  // σ beyond ~1e154: σ² overflows to infinity and the quotient would be ∞/∞; its limit is 1.
  if (std::isinf(sigma2)) return 1.0;
  return sigma2 / (sigma2 + k);
}

// One direction in polar form. The caller has checked that it is finite and strictly above the horizon (z > 0).
struct Polar {
  double theta;      // polar angle from the normal, in [0, π/2)
  double sin_theta;  // from the components, normalised in the (sin, cos) plane so that it never exceeds 1
  double cos_theta;
  double tan_theta;
  double cos_phi, sin_phi;  // azimuth; only meaningful when has_azimuth
  bool has_azimuth;
};

Polar to_polar(const Vec3& w) {
  Polar p;
  const double s = std::hypot(w.x, w.y);  // sin θ for a unit vector, accurate near the normal (unlike sqrt(1 − z²))
  const double c = w.z;
  p.theta = std::atan2(s, c);
  const double r = std::hypot(s, c);
  p.sin_theta = s / r;
  p.cos_theta = c / r;
  p.tan_theta = s / c;
  // Grazing direction whose cos θ is so small (subnormal) that sin θ / cos θ overflows: the true tan θ is beyond the
  // double range. Keep it finite; it only matters when both directions graze like this.
  if (p.tan_theta > kMaxFinite) p.tan_theta = kMaxFinite;
  // sin θ = 0: the direction is the normal and has no azimuth.
  p.has_azimuth = s > 0;
  p.cos_phi = p.has_azimuth ? w.x / s : 1.0;
  p.sin_phi = p.has_azimuth ? w.y / s : 0.0;
  return p;
}

// What both models need about a pair of directions: α = max(θ_i, θ_o), β = min(θ_i, θ_o) and cos Δφ.
// min/max of the per-direction values (sin, tan are increasing in θ, cos decreasing) keeps this symmetric bit for bit.
struct PairGeometry {
  double alpha, beta;
  double sin_alpha;
  double tan_beta;
  double tan_half_sum;  // tan((α + β)/2)
  double cos_dphi;
};

PairGeometry pair_geometry(const Vec3& wo, const Vec3& wi) {
  const Polar o = to_polar(wo), i = to_polar(wi);
  PairGeometry g;
  g.alpha = std::max(o.theta, i.theta);
  g.beta = std::min(o.theta, i.theta);
  g.sin_alpha = std::max(o.sin_theta, i.sin_theta);
  g.tan_beta = std::min(o.tan_theta, i.tan_theta);

  // tan((α + β)/2) = (sin α + sin β) / (cos α + cos β): the half-angle identity, exact in the components and free of
  // the cancellation that tan() of an angle near π/2 suffers.
  const double sin_sum = o.sin_theta + i.sin_theta;
  const double cos_sum = o.cos_theta + i.cos_theta;
  g.tan_half_sum = sin_sum / cos_sum;
  // Both directions graze with subnormal cos θ: the quotient overflows (or cos_sum rounded to 0). Keep it finite.
  if (g.tan_half_sum > kMaxFinite) g.tan_half_sum = kMaxFinite;

  if (o.has_azimuth && i.has_azimuth) {
    // cos(φ_o − φ_i) = cos φ_o cos φ_i + sin φ_o sin φ_i, clamped against rounding just outside [−1, 1].
    g.cos_dphi = std::clamp(o.cos_phi * i.cos_phi + o.sin_phi * i.sin_phi, -1.0, 1.0);
  } else {
    // One direction is the normal (sin θ = 0): Δφ is undefined. Then β = 0, so tan β, (2β/π) and αβ are all zero and
    // every term that cos Δφ multiplies vanishes; any value gives the same result, and 0 says so.
    g.cos_dphi = 0.0;
  }
  return g;
}

}  // namespace

// ---- Full first-order model ---------------------------------------------------------------------------------------

OrenNayar::OrenNayar(const Rgb& albedo, double sigma, bool interreflection)
    : albedo_(albedo), sigma_(sigma), interreflection_(interreflection) {
  c1_ = 1.0 - 0.5 * roughness_ratio(sigma, 0.33);
  c2_scale_ = 0.45 * roughness_ratio(sigma, 0.09);
  c3_scale_ = 0.125 * roughness_ratio(sigma, 0.09);
  interreflection_scale_ = 0.17 * roughness_ratio(sigma, 0.13);
}

Rgb OrenNayar::eval(const Vec3& wo, const Vec3& wi) const {
  if (!valid_reflection_pair(wo, wi)) return Rgb{};
  const PairGeometry g = pair_geometry(wo, wi);

  const double two_beta_over_pi = 2.0 * g.beta * kInvPi;
  const double c2 = g.cos_dphi >= 0
                        ? c2_scale_ * g.sin_alpha
                        : c2_scale_ * (g.sin_alpha - two_beta_over_pi * two_beta_over_pi * two_beta_over_pi);
  const double four_alpha_beta_over_pi2 = 4.0 * g.alpha * g.beta * kInvPi * kInvPi;
  const double c3 = c3_scale_ * four_alpha_beta_over_pi2 * four_alpha_beta_over_pi2;

  double first_order = c1_ + g.cos_dphi * c2 * g.tan_beta + (1.0 - std::fabs(g.cos_dphi)) * c3 * g.tan_half_sum;
  // Departure from the paper: its fit can go negative. For cos Δφ = −1 the C2 term −C2 tan β tends to
  // −0.45 σ²/(σ²+0.09)·6/π as both directions graze, which outweighs C1 once σ > 0.664 rad (forward scattering near
  // the horizon; the fits were made for σ up to about 40°). A BRDF cannot be negative, so the first-order term is
  // clamped at zero there. The clamp is symmetric in (wo, wi), so reciprocity is kept.
  if (first_order < 0) first_order = 0;

  // σ = 0: c2, c3 and the interreflection scale are exactly 0 and c1 exactly 1, so this is ρ · (1/π · 1) = ρ/π,
  // bit for bit what Lambert returns.
  Rgb f = albedo_ * (kInvPi * first_order);
  if (interreflection_) {
    // The two-bounce term goes with ρ² per channel: light reflects off two facets.
    const double bracket = 1.0 - g.cos_dphi * two_beta_over_pi * two_beta_over_pi;
    f += (albedo_ * albedo_) * (kInvPi * interreflection_scale_ * bracket);
  }
  return f;
}

std::optional<BsdfSample> OrenNayar::sample(const Vec3& wo, Point2 u, double) const {
  if (!above_horizon(wo)) return std::nullopt;
  const Vec3 wi = sample_cosine_hemisphere(u);
  return make_sample(wi, eval(wo, wi), pdf(wo, wi));
}

double OrenNayar::pdf(const Vec3& wo, const Vec3& wi) const {
  if (!valid_reflection_pair(wo, wi)) return 0.0;
  return cosine_hemisphere_pdf(wi.z);
}

std::string OrenNayar::describe() const {
  return "oren-nayar(albedo=" + bake::format_rgb(albedo_) + ", sigma=" + bake::format_number(sigma_) +
         ", interreflection=" + (interreflection_ ? "on" : "off") + ")";
}

// ---- Simplified model ---------------------------------------------------------------------------------------------

OrenNayarSimple::OrenNayarSimple(const Rgb& albedo, double sigma) : albedo_(albedo), sigma_(sigma) {
  a_ = 1.0 - 0.5 * roughness_ratio(sigma, 0.33);
  b_ = 0.45 * roughness_ratio(sigma, 0.09);
}

Rgb OrenNayarSimple::eval(const Vec3& wo, const Vec3& wi) const {
  if (!valid_reflection_pair(wo, wi)) return Rgb{};
  const PairGeometry g = pair_geometry(wo, wi);
  // σ = 0: b_ = 0 and a_ = 1 exactly (tan β is finite), so this is exactly Lambert's ρ/π.
  const double bracket = a_ + b_ * std::max(0.0, g.cos_dphi) * g.sin_alpha * g.tan_beta;
  return albedo_ * (kInvPi * bracket);
}

std::optional<BsdfSample> OrenNayarSimple::sample(const Vec3& wo, Point2 u, double) const {
  if (!above_horizon(wo)) return std::nullopt;
  const Vec3 wi = sample_cosine_hemisphere(u);
  return make_sample(wi, eval(wo, wi), pdf(wo, wi));
}

double OrenNayarSimple::pdf(const Vec3& wo, const Vec3& wi) const {
  if (!valid_reflection_pair(wo, wi)) return 0.0;
  return cosine_hemisphere_pdf(wi.z);
}

std::string OrenNayarSimple::describe() const {
  return "oren-nayar-simple(albedo=" + bake::format_rgb(albedo_) + ", sigma=" + bake::format_number(sigma_) + ")";
}

}  // namespace kiln::brdf
