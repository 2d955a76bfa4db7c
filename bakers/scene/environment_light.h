// The environment as a light: radiance arriving from infinitely far along every direction that escapes the scene.
//
// Constant environment (or an image with importance sampling turned off): sampled cosine-weighted about the shading
// normal n (pdf cos θ/π, the ideal strategy for irradiance under constant radiance, so no importance map is built),
// or uniformly over the sphere (pdf 1/4π) when n is zero.
//
// Equirectangular image (the conventions of bakers/envmap/cubemap.h, rotation about +Y as bakers/envmap/env_input.h
// defines it): sampled through a Distribution2D over the image's (u, v) cells. Radiance Le(ω) is the image's bilinear
// interpolation (sample_equirect_bilinear at the unrotated direction — exactly what the environment baker sees). The
// sampled density is piecewise constant per pixel, from the pixel's mean bilinear luminance (the pixel and its 3 × 3
// neighbourhood weighted [1/8, 3/4, 1/8] ⊗ [1/8, 3/4, 1/8]: exactly the mean of the bilinear interpolant over the
// pixel), times sin θ at the pixel centre (the Jacobian of the equirectangular map), so it is positive wherever the
// bilinear Le is: an unbiased estimator even from light samples alone. The density per solid angle is
//     p(ω) = p(u, v) / (2π² sin θ),   θ = π v.
// Le and the density therefore describe different functions (bilinear and piecewise-constant); the statistical tests
// compare the sampler with pdf_li (the same piecewise-constant function), and estimators with analytic integrals of
// Le. An image with no luminance anywhere (all black) gets the sin θ weights: uniform over the sphere.
// Directions at the exact poles (sin θ = 0) have density 0 and are never sampled.
#pragma once

#include <optional>

#include "bakers/envmap/cubemap.h"
#include "bakers/envmap/env_rotation.h"
#include "bakers/scene/distribution.h"
#include "bakers/scene/lights.h"
#include "bakers/scene/scene.h"

namespace kiln::scene {

class EnvironmentLight final : public LightSource {
 public:
  // env.present() must hold. importance_map = false samples an image like a constant (cosine/uniform). Throws
  // std::invalid_argument for an image whose size does not match its width and height.
  explicit EnvironmentLight(const Environment& env, bool importance_map = true);

  LightSamplerKind kind() const override { return LightSamplerKind::environment; }
  bool is_infinite() const override { return true; }
  std::optional<LightSample> sample_li(const Vec3& p, const Vec3& n, Point2 u) const override;
  double pdf_li(const Vec3& p, const Vec3& n, const Vec3& wi, const LightHit& hit) const override;
  Rgb Le(const Vec3& p, const Vec3& wi, const LightHit& hit) const override;
  Rgb power(double scene_radius) const override;

  // The radiance arriving from direction wi (need not be unit).
  Rgb radiance(const Vec3& wi) const;
  bool importance_sampled() const { return importance_; }
  // ∫ L dω over the sphere (exact for the constant; for the image, per pixel its value times its solid angle).
  Rgb integral() const { return integral_; }

  // Rotation about +Y by the environment's angle: world = R_y(α)·image direction (env_rotation.h).
  Vec3 to_world(const Vec3& image_dir) const { return rotation_.to_world(image_dir); }
  Vec3 to_image(const Vec3& world_dir) const { return rotation_.to_image(world_dir); }

 private:
  std::optional<Rgb> constant_;
  envmap::RgbImage image_;
  bool importance_ = false;
  Distribution2D distribution_;
  envmap::EnvRotation rotation_;
  Rgb integral_;
};

}  // namespace kiln::scene
