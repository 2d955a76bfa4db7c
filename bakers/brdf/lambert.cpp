#include "bakers/brdf/lambert.h"

#include "bakers/bake/number_format.h"
#include "bakers/math/constants.h"

namespace kiln::brdf {

Rgb Lambert::eval(const Vec3& wo, const Vec3& wi) const {
  if (!valid_reflection_pair(wo, wi)) return Rgb{};
  return albedo_ * kInvPi;
}

std::optional<BsdfSample> Lambert::sample(const Vec3& wo, Point2 u, double) const {
  if (!above_horizon(wo)) return std::nullopt;
  const Vec3 wi = sample_cosine_hemisphere(u);
  return make_sample(wi, eval(wo, wi), pdf(wo, wi));
}

double Lambert::pdf(const Vec3& wo, const Vec3& wi) const {
  if (!valid_reflection_pair(wo, wi)) return 0.0;
  return cosine_hemisphere_pdf(wi.z);
}

std::string Lambert::describe() const { return "lambert(albedo=" + bake::format_rgb(albedo_) + ")"; }

}  // namespace kiln::brdf
