#include "bakers/brdf/material.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "bakers/bake/number_format.h"
#include "bakers/bake/range_check.h"
#include "bakers/brdf/albedo.h"
#include "bakers/math/constants.h"

namespace kiln::brdf {
namespace {

// E(μ) is smooth in μ; 32 texel-centred nodes with linear interpolation are well within the table's Monte Carlo
// error of about 0.3% (2048 samples per node).
constexpr int kAlbedoNodes = 32;
constexpr int kAlbedoSamples = 2048;

std::vector<Rgb> tabulate(const Bxdf& bxdf) {
  std::vector<Rgb> e(kAlbedoNodes);
  AlbedoOptions options;
  options.samples = kAlbedoSamples;
  for (int i = 0; i < kAlbedoNodes; ++i) {
    const Estimate est = directional_albedo(bxdf, (i + 0.5) / kAlbedoNodes, options);
    // An albedo estimate can exceed 1 by its noise for a lobe that reflects everything; the layering weight
    // 1 − E must not turn negative, so the table holds E clamped to [0, 1].
    e[i] = Rgb{std::clamp(est.value.r, 0.0, 1.0), std::clamp(est.value.g, 0.0, 1.0), std::clamp(est.value.b, 0.0, 1.0)};
  }
  return e;
}

Rgb lookup(const std::vector<Rgb>& table, double mu) {
  const double x = std::clamp(mu, 0.0, 1.0) * kAlbedoNodes - 0.5;
  const int i0 = std::clamp(static_cast<int>(std::floor(x)), 0, kAlbedoNodes - 1);
  const int i1 = std::min(i0 + 1, kAlbedoNodes - 1);
  const double t = std::clamp(x - i0, 0.0, 1.0);
  return lerp(t, table[i0], table[i1]);
}

}  // namespace

std::optional<bake::InvalidInput> validate(const MaterialSpec& spec) {
  if (auto e = validate(spec.diffuse)) return e->under("diffuse");
  if (auto e = validate(spec.specular)) return e->under("specular");
  if (spec.combine == Combine::weights)
    return bake::check_range("specular_weight", spec.specular_weight, bounds::kSpecularWeight);
  return std::nullopt;
}

MaterialSpec without_fresnel(MaterialSpec spec) {
  spec.diffuse = without_fresnel(spec.diffuse);
  spec.specular = without_fresnel(spec.specular);
  return spec;
}

Material::Material(const MaterialSpec& spec) : spec_(spec) {
  if (auto e = validate(spec)) throw *e;
  diffuse_ = make_bxdf(spec.diffuse);
  specular_ = make_bxdf(spec.specular);
  e_specular_ = tabulate(*specular_);
  e_diffuse_ = tabulate(*diffuse_);
}

std::optional<LambertianForm> lambertian_form(const MaterialSpec& spec) {
  if (spec.diffuse.model != Model::lambert) return std::nullopt;
  const Rgb rho_d = spec.diffuse.albedo, rho_s = spec.specular.albedo;
  // A weightless specular lobe reflects nothing, whatever its model.
  if (spec.combine == Combine::weights && spec.specular_weight == 0) return LambertianForm{Rgb{0.0}, rho_d};
  if (spec.specular.model != Model::lambert) return std::nullopt;
  if (spec.combine == Combine::weights) {
    const double s = spec.specular_weight;
    return LambertianForm{rho_s * s, rho_d * (1.0 - s)};
  }
  return LambertianForm{rho_s, (Rgb{1.0} - rho_s) * (Rgb{1.0} - rho_s) * rho_d};
}

Rgb Material::specular_albedo(double mu) const { return lookup(e_specular_, mu); }

Rgb Material::eval(const Vec3& wo, const Vec3& wi) const { return eval(wo, wi, Rgb{1.0}); }

Rgb Material::eval(const Vec3& wo, const Vec3& wi, const Rgb& tint) const {
  if (!valid_reflection_pair(wo, wi)) return Rgb{};
  if (spec_.combine == Combine::weights) {
    const double s = spec_.specular_weight;
    return tint * diffuse_->eval(wo, wi) * (1.0 - s) + specular_->eval(wo, wi) * s;
  }
  const Rgb through = (Rgb{1.0} - lookup(e_specular_, wi.z)) * (Rgb{1.0} - lookup(e_specular_, wo.z));
  return specular_->eval(wo, wi) + through * tint * diffuse_->eval(wo, wi);
}

double Material::specular_probability(double mu_o) const {
  const double es = lookup(e_specular_, mu_o).average();
  const double ed = lookup(e_diffuse_, mu_o).average();
  double spec, diff;
  if (spec_.combine == Combine::weights) {
    spec = spec_.specular_weight * es;
    diff = (1.0 - spec_.specular_weight) * ed;
  } else {
    spec = es;
    diff = (1.0 - es) * (1.0 - es) * ed;  // the energy the base returns, seen through the interface twice
  }
  // Neither lobe reflects anything (black material): sample the diffuse lobe, the weights are all zero anyway.
  if (!(spec + diff > 0)) return 0.0;
  // Keep both strategies alive: a lobe whose tabulated share is tiny may still dominate some directions.
  return std::clamp(spec / (spec + diff), 0.05, 0.95);
}

std::optional<BsdfSample> Material::sample(const Vec3& wo, Point2 u, double uc) const {
  return sample(wo, u, uc, Rgb{1.0});
}

std::optional<BsdfSample> Material::sample(const Vec3& wo, Point2 u, double uc, const Rgb& tint) const {
  if (!above_horizon(wo)) return std::nullopt;
  const double p = specular_probability(wo.z);
  std::optional<BsdfSample> s;
  // uc is reused inside the chosen lobe after rescaling to [0, 1), so lobes that select sub-lobes still get a sample.
  if (uc < p) {
    s = specular_->sample(wo, u, uc / p);
  } else {
    s = diffuse_->sample(wo, u, std::min((uc - p) / (1.0 - p), kOneMinusEpsilon));
  }
  if (!s) return std::nullopt;
  return make_sample(s->wi, eval(wo, s->wi, tint), pdf(wo, s->wi));
}

double Material::pdf(const Vec3& wo, const Vec3& wi) const {
  if (!valid_reflection_pair(wo, wi)) return 0.0;
  const double p = specular_probability(wo.z);
  return p * specular_->pdf(wo, wi) + (1.0 - p) * diffuse_->pdf(wo, wi);
}

std::string Material::describe() const {
  if (spec_.combine == Combine::weights) {
    return "material(weights d=" + bake::format_number(1.0 - spec_.specular_weight) +
           " s=" + bake::format_number(spec_.specular_weight) + ": " + diffuse_->describe() + " + " +
           specular_->describe() + ")";
  }
  return "material(layered: " + specular_->describe() + " over " + diffuse_->describe() + ")";
}

}  // namespace kiln::brdf
