#include "bakers/brdf/fresnel.h"

#include <algorithm>
#include <cmath>

namespace kiln::brdf {

FresnelPolarized fresnel_dielectric_polarized(double cos_theta, double eta) {
  // Outside [0, 1] the cosine is of a direction below the facet or a NaN: clamp the first, reflect nothing for NaN.
  if (std::isnan(cos_theta) || !(eta > 0)) return {0.0, 0.0};
  // eta = 1: no interface at all, nothing is reflected at any angle (the formulas below would give 0/0 at grazing).
  if (eta == 1.0) return {0.0, 0.0};
  // eta so large that eta² overflows (or infinite): the limit of F as eta → ∞ is 1 at every angle.
  if (!std::isfinite(eta * eta)) return {1.0, 1.0};
  const double ci = std::clamp(cos_theta, 0.0, 1.0);
  // Grazing incidence (c = 0): everything is reflected for any eta ≠ 1; below, rounding would land a few ulps off 1.
  if (ci == 0.0) return {1.0, 1.0};
  // The survey's g = sqrt(eta² − 1 + c²) = eta cos θ_t, with eta² − 1 as (eta − 1)(eta + 1) so that eta near 1 keeps
  // its relative precision.
  const double g2 = (eta - 1.0) * (eta + 1.0) + ci * ci;
  // Total internal reflection: only possible for eta < 1, past the critical angle (the survey's g is imaginary).
  // g2 = 0 is the critical angle itself, where F = 1 as well.
  if (!(g2 > 0)) return {1.0, 1.0};
  const double g = std::sqrt(g2);
  // rs = (c − g) / (c + g) and rp = (eta² c − g) / (eta² c + g) (Fresnel's equations with eta cos θ_t = g; their
  // mean is the survey's eq 10). The numerators are rewritten without cancellation:
  //   c² − g² = 1 − eta²,   eta⁴ c² − g² = (eta² − 1)(c² (eta² + 1) − 1).
  // Here g > 0, so both denominators are positive (c ≥ 0, eta > 0).
  const double em1 = (eta - 1.0) * (eta + 1.0);
  const double rs = -em1 / ((ci + g) * (ci + g));
  const double eta2 = eta * eta;
  const double rp = em1 * (ci * ci * (eta2 + 1.0) - 1.0) / ((eta2 * ci + g) * (eta2 * ci + g));
  // Near grazing, rounding can carry the squares an ulp or two past 1; reflectances never exceed 1.
  return {std::fmin(1.0, rs * rs), std::fmin(1.0, rp * rp)};
}

double fresnel_dielectric(double cos_theta, double eta) {
  const FresnelPolarized f = fresnel_dielectric_polarized(cos_theta, eta);
  return 0.5 * (f.rs + f.rp);
}

double fresnel_schlick(double cos_theta, double f0) {
  if (std::isnan(cos_theta)) return f0;
  const double m = 1.0 - std::clamp(cos_theta, 0.0, 1.0);
  const double m2 = m * m;
  return f0 + (1.0 - f0) * m2 * m2 * m;
}

Rgb fresnel_schlick(double cos_theta, const Rgb& f0) {
  return {fresnel_schlick(cos_theta, f0.r), fresnel_schlick(cos_theta, f0.g), fresnel_schlick(cos_theta, f0.b)};
}

double f0_from_eta(double eta) {
  const double r = (eta - 1.0) / (eta + 1.0);
  return r * r;
}

}  // namespace kiln::brdf
