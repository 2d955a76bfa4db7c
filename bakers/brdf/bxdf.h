// The contract every BRDF model of kiln follows.
//
// Frame: all directions are unit vectors in the local shading frame, normal along +z, both pointing AWAY from the
//   surface: `wo` towards the viewer (or the next vertex of a path), `wi` towards the light.
// Reflection only: a model is defined on the upper hemisphere. If wo or wi is at or below the horizon it reflects
//   nothing (eval = 0, pdf = 0, sample fails). A caller that wants two-sided shading flips its frame so that
//   wo.z > 0. "At the horizon" means cos θ ≤ kHorizonCos = 1e-100 (see above_horizon): no measurable light travels
//   that close to a surface, and below it the 1 / (cos θ_i cos θ_o) of the microfacet models leaves the range of
//   doubles. Grazing directions such as cos θ = 1e-7 are ordinary directions.
// eval(wo, wi): the BRDF value f(wo, wi) in 1/sr, per RGB channel, WITHOUT the cosine factor cos θ_i.
// sample(wo, u, uc): draws wi with the model's importance sampling from the uniform sample u ∈ [0,1)² and the
//   lobe-selection sample uc ∈ [0,1). On success it returns wi, f = eval(wo, wi), pdf = pdf(wo, wi) (per unit solid
//   angle, > 0) and weight = f · cos θ_i / pdf. It fails (std::nullopt) when the warped direction falls below the
//   horizon or the density is zero there: that sample simply carries no energy.
// pdf(wo, wi): the density per unit solid angle with which sample() produces wi; it integrates to at most 1 over the
//   hemisphere (less when some samples fail).
// Every result is finite and non-negative for any input: directions with a NaN or Inf component reflect nothing,
//   denormal components are ordinary tiny numbers. Directions are expected to be unit length; the models do not
//   renormalise them. Parameters are validated when a model is built (see model_spec.h), not per call.
#pragma once

#include <optional>
#include <string>

#include "bakers/math/rgb.h"
#include "bakers/math/sampling.h"
#include "bakers/math/vec3.h"

namespace kiln::brdf {

struct BsdfSample {
  Vec3 wi;
  Rgb f;           // eval(wo, wi)
  double pdf = 0;  // pdf(wo, wi), > 0
  Rgb weight;      // f · cos θ_i / pdf
};

class Bxdf {
 public:
  virtual ~Bxdf() = default;

  virtual Rgb eval(const Vec3& wo, const Vec3& wi) const = 0;
  virtual std::optional<BsdfSample> sample(const Vec3& wo, Point2 u, double uc) const = 0;
  virtual double pdf(const Vec3& wo, const Vec3& wi) const = 0;

  // A short description with the parameters, for reports ("ggx(alpha=0.3, fresnel=schlick f0=0.04)").
  virtual std::string describe() const = 0;
  // Helmholtz reciprocity f(wo, wi) = f(wi, wo) holds for this model as configured.
  virtual bool reciprocal() const { return true; }
  // f depends on the azimuths of wo and wi only through their difference, as configured: an estimator averaging
  // over the azimuth of wo may then fix it (albedo.h). False unless a model knows better.
  virtual bool isotropic() const { return false; }
};

inline constexpr double kHorizonCos = 1e-100;

// True when w is finite and above the horizon in the sense of the contract. NaN fails the comparison.
inline bool above_horizon(const Vec3& w) { return w.z > kHorizonCos && is_finite(w); }

// True when both directions are usable for a reflection query.
inline bool valid_reflection_pair(const Vec3& wo, const Vec3& wi) { return above_horizon(wo) && above_horizon(wi); }

// Completes a sample once wi and its density are known; keeps the weight finite where pdf > 0.
inline std::optional<BsdfSample> make_sample(const Vec3& wi, const Rgb& f, double pdf) {
  if (!(pdf > 0) || !std::isfinite(pdf) || !above_horizon(wi)) return std::nullopt;
  return BsdfSample{wi, f, pdf, f * (wi.z / pdf)};
}

}  // namespace kiln::brdf
