// Point, spot and directional lights (KHR_lights_punctual), and the sun: a directional light with a disc.
//
// - Point: intensity I (W·sr⁻¹) at a position; Li = I / r², a delta light.
// - Spot: a point light times glTF's smooth angular falloff (KHR_lights_punctual, "Inner and Outer Cone Angles"):
//       a(cos) = clamp((cos − cos θ_outer) / (cos θ_inner − cos θ_outer), 0, 1)²,
//   with cos the cosine between the cone axis and the direction from the light to p. glTF requires
//   θ_inner < θ_outer; for θ_inner ≥ θ_outer the falloff is the hard cut at θ_outer (the reference code's
//   max(0.001, …) guard would give a steep ramp there instead; the cut is its limit).
// - Directional with angular_diameter = 0: a delta direction; Li = E (irradiance at normal incidence).
// - Sun (angular_diameter = 2 θ_max > 0): a disc of uniform radiance L = E / (π sin² θ_max) in the cone of half-angle
//   θ_max about −direction, so that the irradiance at normal incidence is E = ∫_cone L cos θ dω = L π sin² θ_max.
//   sample_li samples the cone uniformly (pdf 1/Ω, Ω = 2π(1 − cos θ_max)); pdf_li and Le answer for directions
//   inside the cone, so that BSDF-sampled rays that escape into it are combined by MIS.
#pragma once

#include "bakers/scene/lights.h"
#include "bakers/scene/scene.h"

namespace kiln::scene {

class PointLight final : public LightSource {
 public:
  PointLight(const Vec3& position, const Rgb& intensity)
      : position_(position), intensity_(is_finite(position) ? usable_emission(intensity) : Rgb{}) {}
  LightSamplerKind kind() const override { return LightSamplerKind::point; }
  bool is_delta() const override { return true; }
  std::optional<LightSample> sample_li(const Vec3& p, const Vec3& n, Point2 u) const override;
  Rgb power(double scene_radius) const override;
  bool emits_rays() const override { return !intensity_.is_black(); }
  // A direction uniform on the sphere: weight 4π I.
  std::optional<LightEmission> sample_le(Point2 u_position, Point2 u_direction) const override;

 private:
  Vec3 position_;
  Rgb intensity_;
};

class SpotLight final : public LightSource {
 public:
  // axis: the direction the cone points (need not be unit; a zero axis makes a black light).
  SpotLight(const Vec3& position, const Vec3& axis, const Rgb& intensity, double inner_cone, double outer_cone);
  LightSamplerKind kind() const override { return LightSamplerKind::spot; }
  bool is_delta() const override { return true; }
  std::optional<LightSample> sample_li(const Vec3& p, const Vec3& n, Point2 u) const override;
  Rgb power(double scene_radius) const override;
  bool emits_rays() const override { return valid_axis_ && !intensity_.is_black(); }
  // A direction uniform in the outer cone (solid angle Ω = 2π(1 − cos θ_outer)): weight I a(cos) Ω.
  std::optional<LightEmission> sample_le(Point2 u_position, Point2 u_direction) const override;
  // glTF's falloff a(cos) above, cos between the axis and the direction from the light.
  double falloff(double cos_angle) const;

 private:
  Vec3 position_, axis_;
  Rgb intensity_;
  double cos_inner_ = 1, cos_outer_ = 0;
  bool valid_axis_ = true;
};

class DirectionalLight final : public LightSource {
 public:
  // direction: the way light travels (need not be unit; zero makes a black light). angular_diameter in radians:
  // 0 (or not finite) is a delta direction; values above π are read as π (a hemisphere).
  DirectionalLight(const Vec3& direction, const Rgb& irradiance, double angular_diameter);
  LightSamplerKind kind() const override { return disc_ ? LightSamplerKind::sun : LightSamplerKind::directional; }
  bool is_delta() const override { return !disc_; }
  bool uniform_in_solid_angle(const Vec3&) const override { return disc_; }  // sampled uniformly in its cone
  bool is_infinite() const override { return true; }
  std::optional<LightSample> sample_li(const Vec3& p, const Vec3& n, Point2 u) const override;
  double pdf_li(const Vec3& p, const Vec3& n, const Vec3& wi, const LightHit& hit) const override;
  Rgb Le(const Vec3& p, const Vec3& wi, const LightHit& hit) const override;
  Rgb power(double scene_radius) const override;

  Vec3 to_light() const { return to_light_; }  // unit, −direction
  double cone_solid_angle() const { return solid_angle_; }
  Rgb disc_radiance() const { return radiance_; }

 private:
  bool in_cone(const Vec3& wi) const;
  Vec3 to_light_;
  Rgb irradiance_;
  bool disc_ = false;
  double one_minus_cos_max_ = 0;  // 1 − cos θ_max = 2 sin²(θ_max/2), exact for tiny discs
  double solid_angle_ = 0;        // 2π (1 − cos θ_max)
  Rgb radiance_;                  // E / (π sin² θ_max)
  Frame frame_;
};

}  // namespace kiln::scene
