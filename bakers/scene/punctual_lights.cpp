#include "bakers/scene/punctual_lights.h"

#include <algorithm>
#include <cmath>

#include "bakers/math/constants.h"

namespace kiln::scene {

namespace {
bool finite_rgb(const Rgb& c) { return c.is_finite(); }
}  // namespace

std::optional<LightSample> PointLight::sample_li(const Vec3& p, const Vec3& /*n*/, Point2 /*u*/) const {
  const Vec3 d = position_ - p;
  const double r2 = dot(d, d);
  // p at the light itself: no direction and an infinite 1/r²; the light contributes nothing there.
  if (!(r2 > 0)) return std::nullopt;
  const double r = std::sqrt(r2);
  LightSample s;
  s.Li = intensity_ / r2;
  // r² so small that I/r² overflows: the same singularity, reached through rounding.
  if (!finite_rgb(s.Li) || s.Li.is_black()) return std::nullopt;
  s.wi = d / r;
  s.delta = true;
  s.pdf = 0;
  s.distance = r;
  s.point = position_;
  return s;
}

Rgb PointLight::power(double /*scene_radius*/) const { return intensity_ * (4.0 * kPi); }

SpotLight::SpotLight(const Vec3& position, const Vec3& axis, const Rgb& intensity, double inner_cone, double outer_cone)
    : position_(position), intensity_(usable_emission(intensity)) {
  const double len = length(axis);
  valid_axis_ = len > 0 && std::isfinite(len) && is_finite(position);
  axis_ = valid_axis_ ? axis / len : Vec3{0, -1, 0};
  const double outer = std::clamp(outer_cone, 0.0, kPi), inner = std::clamp(inner_cone, 0.0, outer);
  cos_outer_ = std::cos(outer);
  cos_inner_ = std::cos(inner);
}

double SpotLight::falloff(double cos_angle) const {
  // θ_inner ≥ θ_outer (clamped to equal): no ramp, the hard cut at the outer cone.
  if (!(cos_inner_ > cos_outer_)) return cos_angle >= cos_outer_ ? 1.0 : 0.0;
  const double t = std::clamp((cos_angle - cos_outer_) / (cos_inner_ - cos_outer_), 0.0, 1.0);
  return t * t;
}

std::optional<LightSample> SpotLight::sample_li(const Vec3& p, const Vec3& /*n*/, Point2 /*u*/) const {
  if (!valid_axis_) return std::nullopt;
  const Vec3 d = position_ - p;
  const double r2 = dot(d, d);
  if (!(r2 > 0)) return std::nullopt;  // p at the light: see PointLight
  const double r = std::sqrt(r2);
  const Vec3 wi = d / r;
  const double a = falloff(dot(-wi, axis_));
  if (a == 0) return std::nullopt;  // outside the cone
  LightSample s;
  s.Li = intensity_ * (a / r2);
  if (!finite_rgb(s.Li) || s.Li.is_black()) return std::nullopt;
  s.wi = wi;
  s.delta = true;
  s.distance = r;
  s.point = position_;
  return s;
}

Rgb SpotLight::power(double /*scene_radius*/) const {
  if (!valid_axis_) return Rgb{};
  // ∫ a dω = 2π [ (1 − cos θ_i) + ∫_{cos θ_o}^{cos θ_i} ((μ − cos θ_o)/(cos θ_i − cos θ_o))² dμ ]
  //        = 2π [ (1 − cos θ_i) + (cos θ_i − cos θ_o)/3 ].
  return intensity_ * (2.0 * kPi * ((1.0 - cos_inner_) + (cos_inner_ - cos_outer_) / 3.0));
}

DirectionalLight::DirectionalLight(const Vec3& direction, const Rgb& irradiance, double angular_diameter)
    : irradiance_(usable_emission(irradiance)) {
  const double len = length(direction);
  // A zero or non-finite direction has nowhere to shine: a black light.
  if (!(len > 0) || !std::isfinite(len)) irradiance_ = Rgb{};
  to_light_ = (len > 0 && std::isfinite(len)) ? -direction / len : Vec3{0, 1, 0};
  frame_ = Frame::from_normal(to_light_);
  disc_ = std::isfinite(angular_diameter) && angular_diameter > 0;
  if (disc_) {
    const double theta_max = 0.5 * std::min(angular_diameter, kPi);
    const double s_half = std::sin(0.5 * theta_max), s_max = std::sin(theta_max);
    one_minus_cos_max_ = 2.0 * s_half * s_half;
    solid_angle_ = 2.0 * kPi * one_minus_cos_max_;
    radiance_ = irradiance_ / (kPi * s_max * s_max);
    // A diameter so small that sin² θ_max underflows: the disc cannot be represented; keep the delta direction.
    if (!(one_minus_cos_max_ > 0) || !radiance_.is_finite()) {
      disc_ = false;
      radiance_ = Rgb{};
    }
  }
}

bool DirectionalLight::in_cone(const Vec3& wi) const {
  // 1 − cos θ from the chord, |wi − a|²/2, which keeps its precision for the 0.5° sun where 1 − dot(wi, a) would
  // lose half the digits.
  const Vec3 d = wi - to_light_;
  return 0.5 * dot(d, d) <= one_minus_cos_max_;
}

std::optional<LightSample> DirectionalLight::sample_li(const Vec3& /*p*/, const Vec3& /*n*/, Point2 u) const {
  if (irradiance_.is_black()) return std::nullopt;
  LightSample s;
  s.distance = kInfinity;
  if (!disc_) {
    s.wi = to_light_;
    s.Li = irradiance_;
    s.delta = true;
    s.point = to_light_;  // unused for infinite lights
    return s;
  }
  // Uniform in the cone: 1 − cos θ = u₀ (1 − cos θ_max), sin θ from (1 − cos)(1 + cos) without cancellation.
  const double one_minus_cos = u.x * one_minus_cos_max_;
  const double cos_theta = 1.0 - one_minus_cos;
  const double sin_theta = std::sqrt(std::fmax(0.0, one_minus_cos * (2.0 - one_minus_cos)));
  const double phi = 2.0 * kPi * u.y;
  s.wi = normalize(frame_.from_local({sin_theta * std::cos(phi), sin_theta * std::sin(phi), cos_theta}));
  s.Li = radiance_;
  s.pdf = 1.0 / solid_angle_;
  s.point = s.wi;
  return s;
}

double DirectionalLight::pdf_li(const Vec3& /*p*/, const Vec3& /*n*/, const Vec3& wi, const LightHit& /*hit*/) const {
  if (!disc_ || irradiance_.is_black()) return 0.0;
  return in_cone(wi) ? 1.0 / solid_angle_ : 0.0;
}

Rgb DirectionalLight::Le(const Vec3& /*p*/, const Vec3& wi, const LightHit& /*hit*/) const {
  if (!disc_) return Rgb{};
  return in_cone(wi) ? radiance_ : Rgb{};
}

Rgb DirectionalLight::power(double scene_radius) const {
  // The irradiance at normal incidence over the scene's cross-section.
  return irradiance_ * (kPi * scene_radius * scene_radius);
}

// ---- Light tracing ----

std::optional<LightEmission> PointLight::sample_le(Point2 /*u_position*/, Point2 u_direction) const {
  if (intensity_.is_black()) return std::nullopt;
  LightEmission e;
  e.origin = position_;
  e.direction = sample_uniform_sphere(u_direction);
  e.weight = intensity_ * (4.0 * kPi);
  return e;
}

std::optional<LightEmission> SpotLight::sample_le(Point2 /*u_position*/, Point2 u_direction) const {
  if (!valid_axis_ || intensity_.is_black()) return std::nullopt;
  // Uniform in the outer cone: cos θ uniform in [cos θ_outer, 1].
  const double cos_theta = 1.0 - u_direction.x * (1.0 - cos_outer_);
  const double sin_theta = std::sqrt(std::max(0.0, 1.0 - cos_theta * cos_theta));
  const double phi = 2.0 * kPi * u_direction.y;
  LightEmission e;
  e.origin = position_;
  e.direction = Frame::from_normal(axis_).from_local({sin_theta * std::cos(phi), sin_theta * std::sin(phi), cos_theta});
  const double a = falloff(cos_theta);
  if (a == 0) return std::nullopt;  // on the outer cone's rim
  e.weight = intensity_ * (a * 2.0 * kPi * (1.0 - cos_outer_));
  return e;
}

}  // namespace kiln::scene
