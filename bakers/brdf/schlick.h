// Schlick 1994, "An Inexpensive BRDF Model for Physically-based Rendering": the single-layer model with roughness r
// and isotropy p, and the double-layer model, in an energy-conserving form (schlick.cpp). Where and why it departs
// from the survey's printed eq 23 and eq 25: docs/BRDF.md, section "Schlick's model".
#pragma once

#include "bakers/brdf/bxdf.h"
#include "bakers/brdf/model_spec.h"

namespace kiln::brdf {

class SchlickSingle final : public Bxdf {
 public:
  explicit SchlickSingle(const SchlickLayer& layer);
  ~SchlickSingle() override;

  Rgb eval(const Vec3& wo, const Vec3& wi) const override;
  std::optional<BsdfSample> sample(const Vec3& wo, Point2 u, double uc) const override;
  double pdf(const Vec3& wo, const Vec3& wi) const override;
  std::string describe() const override;
  bool isotropic() const override;  // p = 1 (for the double layer: in both layers)

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

class SchlickDouble final : public Bxdf {
 public:
  SchlickDouble(const SchlickLayer& top, const SchlickLayer& bottom);
  ~SchlickDouble() override;

  Rgb eval(const Vec3& wo, const Vec3& wi) const override;
  std::optional<BsdfSample> sample(const Vec3& wo, Point2 u, double uc) const override;
  double pdf(const Vec3& wo, const Vec3& wi) const override;
  std::string describe() const override;
  bool isotropic() const override;  // p = 1 (for the double layer: in both layers)

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace kiln::brdf
