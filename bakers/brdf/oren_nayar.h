// Oren & Nayar 1994/1995: diffuse reflection from rough surfaces of V-cavities with Lambertian facets whose slope
// angles are Gaussian with standard deviation sigma (radians). sigma = 0 reduces exactly to Lambert.
#pragma once

#include "bakers/brdf/bxdf.h"

namespace kiln::brdf {

// The full first-order model (C1, C2 with its two branches, C3), optionally with the two-bounce interreflection term.
// Where the paper's first-order fit turns negative (σ > 0.664 rad, forward scattering near the horizon) it is clamped
// at zero. Measured albedo (ρ = 1, tests/brdf/oren_nayar_test.cpp): up to 1.0033 without and 1.050 with the
// interreflection term, at grazing θo.
class OrenNayar final : public Bxdf {
 public:
  OrenNayar(const Rgb& albedo, double sigma, bool interreflection);

  Rgb eval(const Vec3& wo, const Vec3& wi) const override;
  std::optional<BsdfSample> sample(const Vec3& wo, Point2 u, double uc) const override;
  double pdf(const Vec3& wo, const Vec3& wi) const override;
  std::string describe() const override;
  bool isotropic() const override { return true; }

 private:
  Rgb albedo_;
  double sigma_;
  bool interreflection_;
  // Precomputed from sigma: C1, the σ-dependent factors of C2 and C3, and 0.17 σ²/(σ²+0.13) of the two-bounce term.
  double c1_, c2_scale_, c3_scale_, interreflection_scale_;
};

// The simplified A/B model (survey eq 27). Measured albedo (ρ = 1): up to 1.0151 at grazing θo (σ = 0.2 rad).
class OrenNayarSimple final : public Bxdf {
 public:
  OrenNayarSimple(const Rgb& albedo, double sigma);

  Rgb eval(const Vec3& wo, const Vec3& wi) const override;
  std::optional<BsdfSample> sample(const Vec3& wo, Point2 u, double uc) const override;
  double pdf(const Vec3& wo, const Vec3& wi) const override;
  std::string describe() const override;
  bool isotropic() const override { return true; }

 private:
  Rgb albedo_;
  double sigma_;
  double a_, b_;  // A = 1 − 0.5 σ²/(σ²+0.33), B = 0.45 σ²/(σ²+0.09)
};

}  // namespace kiln::brdf
