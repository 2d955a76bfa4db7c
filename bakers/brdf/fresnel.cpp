#include "bakers/brdf/fresnel.h"

#include <algorithm>
#include <cmath>

namespace kiln::brdf {

FresnelPolarized fresnel_dielectric_polarized(double cos_theta, double eta) {
  // Outside [0, 1] the cosine is of a direction below the facet or a NaN: clamp the first, reflect nothing for NaN.
  if (std::isnan(cos_theta) || !(eta > 0)) return {0.0, 0.0};
  // eta = 1: no interface at all, nothing is reflected at any angle (the formulas below would give 0/0 at grazing).
  if (eta == 1.0) return {0.0, 0.0};
  const double ci = std::clamp(cos_theta, 0.0, 1.0);
  const double eta2 = eta * eta;
  // eta so small that eta² underflows: every angle is past the critical angle, and at normal incidence the limit of
  // ((eta − 1)/(eta + 1))² is 1 too. (validate() keeps eta far from this; the guard keeps F finite for any input.)
  if (!(eta2 > 0)) return {1.0, 1.0};
  const double sin2_t = (1.0 - ci * ci) / eta2;  // Snell's law
  // Total internal reflection: only possible for eta < 1, past the critical angle (the survey's g is imaginary).
  if (sin2_t >= 1.0) return {1.0, 1.0};
  const double ct = std::sqrt(1.0 - sin2_t);
  // Here ct > 0 and eta > 0, so both denominators are positive. This polarised form is algebraically the survey's
  // eq 10 (Cook–Torrance's unpolarised formula in c and g = eta·ct); it also exposes rp for Brewster's angle.
  const double rs = (ci - eta * ct) / (ci + eta * ct);
  const double rp = (eta * ci - ct) / (eta * ci + ct);
  return {rs * rs, rp * rp};
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
