#include "bakers/brdf/microfacet.h"

#include <algorithm>
#include <cmath>

#include "bakers/bake/number_format.h"
#include "bakers/brdf/fresnel.h"
#include "bakers/math/constants.h"

namespace kiln::brdf {

double g_vgroove(const Vec3& wo, const Vec3& wi, const Vec3& wh) {
  // Survey eq 12 is correct as printed: for the half vector wo·wh = wi·wh, so both fractions share it.
  // wo·wh = wi·wh for the half vector; their mean is the same number computed symmetrically, so that swapping wo
  // and wi gives bit-identical results (reciprocity to the last bit).
  const double o_dot_h = 0.5 * (dot(wo, wh) + dot(wi, wh));
  if (!(o_dot_h > 0) || !(wh.z > 0)) return 0.0;  // a back-facing facet neither reflects nor is seen
  const double k = 2.0 * wh.z / o_dot_h;
  return std::clamp(std::fmin(k * wo.z, k * wi.z), 0.0, 1.0);
}

double g1_schlick(double cos_theta, double alpha) {
  // Survey eq 19 with the scalar v = n·w; k = α sqrt(2/π) fits the Smith–Beckmann G1 (Schlick 1994).
  if (!(cos_theta > 0)) return 0.0;
  const double k = alpha * std::sqrt(2.0 / kPi);
  return cos_theta / (cos_theta - k * cos_theta + k);
}

MicrofacetBrdf::MicrofacetBrdf(const MicrofacetParams& params)
    : params_(params), distribution_(params.distribution, params.alpha_x, params.alpha_y) {}

double MicrofacetBrdf::G(const Vec3& wo, const Vec3& wi, const Vec3& wh) const {
  switch (params_.masking) {
    case Masking::separable:
      return distribution_.G1(wo) * distribution_.G1(wi);
    case Masking::height_correlated:
      // Heitz 2014, eq 99: the masking of wo and the shadowing of wi are correlated through the height of the point.
      return 1.0 / (1.0 + (distribution_.Lambda(wo) + distribution_.Lambda(wi)));  // grouped: symmetric in wo, wi
    case Masking::v_groove:
      return g_vgroove(wo, wi, wh);
    case Masking::schlick: {
      const double alpha = std::sqrt(distribution_.alpha_x() * distribution_.alpha_y());
      return g1_schlick(wo.z, alpha) * g1_schlick(wi.z, alpha);
    }
  }
  return 0.0;
}

Rgb MicrofacetBrdf::F(double cos_theta_h) const {
  switch (params_.fresnel) {
    case FresnelMode::none:
      return Rgb{1.0};
    case FresnelMode::schlick:
      return fresnel_schlick(cos_theta_h, params_.f0);
    case FresnelMode::exact:
      return Rgb{fresnel_dielectric(cos_theta_h, params_.eta)};
  }
  return Rgb{1.0};
}

Rgb MicrofacetBrdf::eval(const Vec3& wo, const Vec3& wi) const {
  if (!valid_reflection_pair(wo, wi)) return Rgb{};
  // wo.z > 0 and wi.z > 0, so wo + wi has a positive z and never vanishes (not even for wi = −wo, excluded here).
  const Vec3 wh = normalize(wo + wi);
  const double d = distribution_.D(wh);
  if (d == 0.0) return Rgb{};
  const double g = G(wo, wi, wh);
  // Every factor below is computed symmetrically in wo and wi (the products grouped, the Fresnel cosine as the mean
  // of wo·wh and wi·wh), so that f(wo, wi) and f(wi, wo) are the same bits. This matters where F is steep: near the
  // critical angle of eta < 1 a rounding difference in the cosine changes F by orders of magnitude more.
  const double denom = (params_.normalization == Normalization::four ? 4.0 : kPi) * (wo.z * wi.z);
  // Grazing pairs make denom tiny, and the V-groove G stays 1 near the mirror direction, so f is huge there; it
  // stays finite because valid_reflection_pair keeps both cosines above kHorizonCos = 1e-100 and D ≤ 1/(π α_x α_y).
  // It is large, but the cosine that multiplies it in any integral is not.
  return F(0.5 * (dot(wo, wh) + dot(wi, wh))) * (d * g / denom);
}

bool MicrofacetBrdf::samples_v_cavity() const {
  // The V-groove G is the masking of the V-cavity microsurface: its visible normals make the weight F G / G1(wo) ≤ F.
  // Schlick's rational D has no Smith Λ of its own (it borrows Beckmann's), so it has no Smith visible normals; its
  // V-cavity ones keep the weight bounded at grazing wo, where D cos θ_h sampling is not (see BRDF.md).
  return params_.masking == Masking::v_groove || params_.distribution == Distribution::schlick_beckmann;
}

std::optional<BsdfSample> MicrofacetBrdf::sample(const Vec3& wo, Point2 u, double) const {
  if (!above_horizon(wo)) return std::nullopt;
  const Vec3 wh = samples_v_cavity() ? distribution_.sample_wh_v_cavity(wo, u) : distribution_.sample_wh(wo, u);
  const double o_dot_h = dot(wo, wh);
  // Visible normals face wo; rounding at a grazing facet can still give o·h ≤ 0, which reflects nothing.
  if (!(o_dot_h > 0)) return std::nullopt;
  const Vec3 wi = reflect(wo, wh);
  if (!above_horizon(wi)) return std::nullopt;  // reflected below the horizon: masked in reality, no energy here
  return make_sample(wi, eval(wo, wi), pdf(wo, wi));
}

double MicrofacetBrdf::pdf(const Vec3& wo, const Vec3& wi) const {
  if (!valid_reflection_pair(wo, wi)) return 0.0;
  const Vec3 wh = normalize(wo + wi);
  const double o_dot_h = dot(wo, wh);
  if (!(o_dot_h > 0)) return 0.0;
  // Jacobian of the reflection map wh -> wi: dω_h / dω_i = 1 / (4 wo·wh).
  const double pdf_h = samples_v_cavity() ? distribution_.pdf_wh_v_cavity(wo, wh) : distribution_.pdf_wh(wo, wh);
  return pdf_h / (4.0 * o_dot_h);
}

std::string MicrofacetBrdf::describe() const {
  std::string s = "microfacet(D=" + to_string(params_.distribution);
  if (params_.alpha_x == params_.alpha_y) {
    s += ", alpha=" + bake::format_number(params_.alpha_x);
  } else {
    s += ", alpha_x=" + bake::format_number(params_.alpha_x) + ", alpha_y=" + bake::format_number(params_.alpha_y);
  }
  s += ", G=" + to_string(params_.masking) + ", fresnel=" + to_string(params_.fresnel);
  if (params_.fresnel == FresnelMode::schlick) s += " f0=" + bake::format_rgb(params_.f0);
  if (params_.fresnel == FresnelMode::exact) s += " eta=" + bake::format_number(params_.eta);
  s += ", normalization=" + to_string(params_.normalization) + ")";
  return s;
}

}  // namespace kiln::brdf
