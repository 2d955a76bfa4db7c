// A material: a diffuse lobe and a specular lobe combined so that energy is kept, in one of two ways.
//
//  weights  f = d f_diffuse + s f_specular with d + s = 1 (Cook & Torrance 1982; survey eq 7). Energy is kept because
//           each lobe conserves it and the weights sum to one; the split does not depend on the angle.
//  layered  f = f_specular + (1 − E_s(μ_i)) (1 − E_s(μ_o)) f_diffuse, where E_s(μ) is the directional albedo of the
//           specular lobe with its Fresnel term. This is Schlick's Fresnel-weighted layering (the diffuse part gets
//           what the specular surface does not reflect, more at normal incidence, less at grazing) in the
//           directional-albedo form of Kelemen & Szirmay-Kalos 2001: light enters the base through the interface
//           and leaves through it again. Reciprocal, and the albedo is at most E_s + (1 − E_s) E_d ≤ 1 for any base.
//           Light reflected back down by the interface from below is not returned (a measured loss, see the tests);
//           Schlick's pointwise (1 − S(u)) form is not used because it does not bound the albedo.
#pragma once

#include <memory>
#include <vector>

#include "bakers/brdf/bxdf.h"
#include "bakers/brdf/model_spec.h"

namespace kiln::brdf {

enum class Combine { weights, layered };

struct MaterialSpec {
  ModelSpec diffuse;   // usually lambert or oren-nayar
  ModelSpec specular;  // usually ggx, beckmann or cook-torrance with a Fresnel term
  Combine combine = Combine::layered;
  double specular_weight = 0.5;  // s for Combine::weights; d = 1 − s
};

std::optional<bake::InvalidInput> validate(const MaterialSpec& spec);

// The white-furnace form: both lobes white and without Fresnel (brdf::without_fresnel), combined as before.
MaterialSpec without_fresnel(MaterialSpec spec);

// The closed form of a material whose two lobes are both Lambertian (as the lightmap planner leaves a pruned
// specular lobe): it reflects the same for every pair of directions above the horizon, f(wo, wi, tint) =
// (A + B·tint)/π, so a renderer may shade it without the general machinery. Weights: A = s ρ_s, B = (1 − s) ρ_d.
// Layered: A = ρ_s, B = (1 − ρ_s)² ρ_d, since a Lambertian lobe's directional albedo is ρ_s at every angle (Material
// tabulates it; the two agree to the table's accuracy). A Lambertian diffuse lobe with a weightless specular lobe of
// any model (weights, s = 0) is the first case with A = 0. nullopt for any other material.
struct LambertianForm {
  Rgb A, B;
};
std::optional<LambertianForm> lambertian_form(const MaterialSpec& spec);

class Material final : public Bxdf {
 public:
  // Throws validate()'s bake::InvalidInput if the spec is invalid.
  explicit Material(const MaterialSpec& spec);

  Rgb eval(const Vec3& wo, const Vec3& wi) const override;
  std::optional<BsdfSample> sample(const Vec3& wo, Point2 u, double uc) const override;
  double pdf(const Vec3& wo, const Vec3& wi) const override;
  std::string describe() const override;

  // The same with the diffuse lobe multiplied by `tint` (a base colour, or a texture read at the shading point):
  // both combinations are linear in the diffuse term, so the tinted material keeps its energy bound for tint ≤ 1.
  // The sampling probabilities are the untinted material's; the pdf does not depend on the tint.
  Rgb eval(const Vec3& wo, const Vec3& wi, const Rgb& tint) const;
  std::optional<BsdfSample> sample(const Vec3& wo, Point2 u, double uc, const Rgb& tint) const;

  bool reciprocal() const override { return diffuse_->reciprocal() && specular_->reciprocal(); }

  // The specular lobe's directional albedo E_s(μ) as tabulated (per channel), for tests and reports.
  Rgb specular_albedo(double mu) const;

 private:
  // Probability of sampling the specular lobe from wo: its share of the expected reflected energy.
  double specular_probability(double mu_o) const;

  MaterialSpec spec_;
  std::unique_ptr<Bxdf> diffuse_, specular_;
  std::vector<Rgb> e_specular_, e_diffuse_;  // directional albedo at μ = (i + 0.5) / n
};

}  // namespace kiln::brdf
