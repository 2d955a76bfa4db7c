#include "bakers/scene/environment_light.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "bakers/math/constants.h"

namespace kiln::scene {

EnvironmentLight::EnvironmentLight(const Environment& env, bool importance_map)
    : rotation_(env.rotation_degrees) {  // the environment baker's rotation (env_rotation.h), to the last bit
  if (env.constant || env.equirect.empty()) {
    const Rgb c = env.constant.value_or(Rgb{});
    constant_ = usable_emission(c);
    integral_ = *constant_ * (4.0 * kPi);
    return;
  }
  const int w = env.width, h = env.height;
  if (w < 1 || h < 1 || env.equirect.size() != static_cast<size_t>(w) * static_cast<size_t>(h))
    throw std::invalid_argument("environment light: the equirectangular image holds " +
                                std::to_string(env.equirect.size()) +
                                " texels, not width × height = " + std::to_string(w) + " × " + std::to_string(h));
  image_ = envmap::RgbImage(w, h);
  for (size_t i = 0; i < env.equirect.size(); ++i) {
    const Rgb& c = env.equirect[i];
    // Non-finite or negative texels are not radiance (the decoder already replaces them; a scene built by hand may
    // not have been decoded): read as 0.
    image_.pixels[i] = usable_emission(c);
  }
  // Per-pixel solid angle Δφ (cos θ0 − cos θ1) for the integral (and power).
  for (int y = 0; y < h; ++y) {
    const double omega = 2.0 * kPi / w * (std::cos(kPi * y / h) - std::cos(kPi * (y + 1) / h));
    Rgb row;
    for (int x = 0; x < w; ++x) row += image_.at(x, y);
    integral_ += row * omega;
  }
  importance_ = importance_map;
  if (!importance_) return;

  std::vector<double> lum(static_cast<size_t>(w) * h);
  for (size_t i = 0; i < lum.size(); ++i) lum[i] = luminance(image_.pixels[i]);
  const double k[3] = {0.125, 0.75, 0.125};
  std::vector<double> weights(lum.size());
  double total = 0;
  for (int y = 0; y < h; ++y) {
    const double sin_theta = std::sin(kPi * (y + 0.5) / h);
    for (int x = 0; x < w; ++x) {
      double m = 0;
      for (int dy = -1; dy <= 1; ++dy) {
        const int yy = std::clamp(y + dy, 0, h - 1);  // the rows clamp at the poles, as the bilinear lookup does
        for (int dx = -1; dx <= 1; ++dx) {
          const int xx = ((x + dx) % w + w) % w;  // longitude wraps around
          m += k[dy + 1] * k[dx + 1] * lum[static_cast<size_t>(yy) * w + xx];
        }
      }
      weights[static_cast<size_t>(y) * w + x] = m * sin_theta;
      total += m * sin_theta;
    }
  }
  // An image without luminance (black, or so dim the weights underflow): uniform over the sphere, finite pdfs.
  if (!(total > 0) || !std::isfinite(total)) {
    for (int y = 0; y < h; ++y) {
      const double sin_theta = std::sin(kPi * (y + 0.5) / h);
      for (int x = 0; x < w; ++x) weights[static_cast<size_t>(y) * w + x] = sin_theta;
    }
  }
  distribution_ = Distribution2D(weights, w, h);
}

Rgb EnvironmentLight::radiance(const Vec3& wi) const {
  if (constant_) return *constant_;
  return envmap::sample_equirect_bilinear(image_, to_image(wi));
}

std::optional<LightSample> EnvironmentLight::sample_li(const Vec3& /*p*/, const Vec3& n, Point2 u) const {
  if (integral_.is_black()) return std::nullopt;
  LightSample s;
  s.distance = kInfinity;
  if (!importance_) {
    const double ln = length(n);
    if (ln > 0 && std::isfinite(ln)) {
      const Vec3 w = sample_cosine_hemisphere(u);
      // The centre of the disk maps to the normal; a sample on the rim (w.z = 0) is tangent: density 0, dropped.
      if (!(w.z > 0)) return std::nullopt;
      s.wi = Frame::from_normal(n / ln).from_local(w);
      s.pdf = w.z * kInvPi;
    } else {
      s.wi = sample_uniform_sphere(u);
      s.pdf = kInv4Pi;
    }
  } else {
    const auto d = distribution_.sample(u);
    const double theta = kPi * d.uv.y;
    const double sin_theta = std::sin(theta);
    if (!(sin_theta > 0) || !(d.pdf > 0)) return std::nullopt;  // exactly at a pole: no solid angle
    s.wi = to_world(envmap::equirect_uv_to_direction(d.uv.x, d.uv.y));
    s.pdf = d.pdf / (2.0 * kPi * kPi * sin_theta);
  }
  s.Li = radiance(s.wi);
  s.point = s.wi;
  return s;
}

double EnvironmentLight::pdf_li(const Vec3& /*p*/, const Vec3& n, const Vec3& wi, const LightHit& /*hit*/) const {
  if (integral_.is_black()) return 0.0;
  if (!importance_) {
    const double ln = length(n);
    if (ln > 0 && std::isfinite(ln)) return cosine_hemisphere_pdf(dot(n / ln, wi));  // wi is unit by contract
    return kInv4Pi;
  }
  double u, v;
  envmap::direction_to_equirect_uv(to_image(wi), u, v);
  const double sin_theta = std::sin(kPi * v);
  if (!(sin_theta > 0)) return 0.0;  // the poles have no solid angle
  return distribution_.pdf({u, v}) / (2.0 * kPi * kPi * sin_theta);
}

Rgb EnvironmentLight::Le(const Vec3& /*p*/, const Vec3& wi, const LightHit& /*hit*/) const { return radiance(wi); }

Rgb EnvironmentLight::power(double scene_radius) const {
  // Radiance over the sphere falling on the scene's cross-section: π R² ∫ L dω (pbrt-v4's ImageInfiniteLight::Phi).
  return integral_ * (kPi * scene_radius * scene_radius);
}

}  // namespace kiln::scene
