// Lambert: f = ρ / π, sampled with the cosine-weighted hemisphere.
#pragma once

#include "bakers/brdf/bxdf.h"

namespace kiln::brdf {

class Lambert final : public Bxdf {
 public:
  explicit Lambert(const Rgb& albedo) : albedo_(albedo) {}

  Rgb eval(const Vec3& wo, const Vec3& wi) const override;
  std::optional<BsdfSample> sample(const Vec3& wo, Point2 u, double uc) const override;
  double pdf(const Vec3& wo, const Vec3& wi) const override;
  std::string describe() const override;
  bool isotropic() const override { return true; }

 private:
  Rgb albedo_;
};

}  // namespace kiln::brdf
