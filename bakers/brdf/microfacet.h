// The microfacet BRDF f = F(wo·wh) G(wo, wi) D(wh) / (4 (n·wi)(n·wo)) (Walter et al. 2007, eq 20; survey eq 14),
// with D, G, F and the normalisation selectable: this one class is Cook–Torrance, GGX and Beckmann, and carries
// Schlick's approximations in place of the exact terms.
#pragma once

#include "bakers/brdf/bxdf.h"
#include "bakers/brdf/microfacet_distribution.h"
#include "bakers/brdf/model_spec.h"

namespace kiln::brdf {

struct MicrofacetParams {
  Distribution distribution = Distribution::ggx;
  double alpha_x = 0.3, alpha_y = 0.3;
  Masking masking = Masking::separable;
  FresnelMode fresnel = FresnelMode::none;
  Rgb f0{0.04};
  double eta = 1.5;
  Normalization normalization = Normalization::four;
};

class MicrofacetBrdf final : public Bxdf {
 public:
  explicit MicrofacetBrdf(const MicrofacetParams& params);

  Rgb eval(const Vec3& wo, const Vec3& wi) const override;
  std::optional<BsdfSample> sample(const Vec3& wo, Point2 u, double uc) const override;
  double pdf(const Vec3& wo, const Vec3& wi) const override;
  std::string describe() const override;
  // α_x = α_y (Schlick's rational D is always isotropic).
  bool isotropic() const override { return distribution_.alpha_x() == distribution_.alpha_y(); }

  const MicrofacetDistribution& distribution() const { return distribution_; }
  // The shadowing-masking term G(wo, wi) for the half vector wh, as configured.
  double G(const Vec3& wo, const Vec3& wi, const Vec3& wh) const;
  // The Fresnel term at c = wo·wh, as configured.
  Rgb F(double cos_theta_h) const;

 private:
  // Which visible normals sample() draws: the V-cavity ones (V-groove masking, Schlick's rational D) or the
  // distribution's own Smith ones.
  bool samples_v_cavity() const;

  MicrofacetParams params_;
  MicrofacetDistribution distribution_;
};

// The V-groove shadowing-masking of Torrance–Sparrow and Cook–Torrance (survey eq 12):
// min(1, 2 (n·h)(n·o)/(o·h), 2 (n·h)(n·i)/(o·h)).
double g_vgroove(const Vec3& wo, const Vec3& wi, const Vec3& wh);
// Schlick's rational approximation of Smith's G1 for Beckmann (survey eq 19): v / (v − k v + k), k = alpha sqrt(2/π).
double g1_schlick(double cos_theta, double alpha);

}  // namespace kiln::brdf
