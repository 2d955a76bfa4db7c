// Fresnel reflectance of a smooth dielectric interface, exact and in Schlick's approximation.
#pragma once

#include "bakers/math/rgb.h"

namespace kiln::brdf {

// Exact unpolarised reflectance (Cook & Torrance 1982, survey eq 10–11): c = cos θ (the angle between the incident
// direction and the facet normal, c ∈ [0, 1]), eta = n_t / n_i. For eta < 1 past the critical angle (g² < 0)
// the reflection is total and F = 1.
double fresnel_dielectric(double cos_theta, double eta);

// The s- and p-polarised parts whose mean is fresnel_dielectric(); used to check Brewster's angle.
struct FresnelPolarized {
  double rs = 0, rp = 0;
};
FresnelPolarized fresnel_dielectric_polarized(double cos_theta, double eta);

// Schlick 1994 (survey eq 18): f0 + (1 − f0)(1 − cos θ)^5.
double fresnel_schlick(double cos_theta, double f0);
Rgb fresnel_schlick(double cos_theta, const Rgb& f0);

// Reflectance at normal incidence of an interface with relative index eta: ((eta − 1) / (eta + 1))².
double f0_from_eta(double eta);

}  // namespace kiln::brdf
