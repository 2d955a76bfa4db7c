// The environment's rotation about +Y (the convention env_input.h defines): right-handed, counter-clockwise seen
// from above, world direction = R_y(α)·image direction. Every reader of a rotated environment (sample_environment,
// faces_to_cube, scene::EnvironmentLight) goes through this one class, so that they all look the image up at exactly
// the same direction for the same angle.
#pragma once

#include <cmath>

#include "bakers/math/constants.h"
#include "bakers/math/vec3.h"

namespace kiln::envmap {

class EnvRotation {
 public:
  EnvRotation() = default;  // no rotation

  // α in degrees, any finite value. It is reduced modulo 360 before the conversion to radians, so that large angles
  // keep their digits. A non-finite angle (decode_environment refuses one; a scene built by hand may still carry it)
  // is read as no rotation rather than turning every direction into NaN.
  explicit EnvRotation(double degrees) {
    const double a = std::fmod(degrees, 360.0) * (kPi / 180.0);
    if (!std::isfinite(a)) return;
    cos_ = std::cos(a);
    sin_ = std::sin(a);
  }

  // R_y(−α)·d: the direction at which the unrotated image is read for the world direction d.
  Vec3 to_image(const Vec3& d) const { return {d.x * cos_ - d.z * sin_, d.y, d.x * sin_ + d.z * cos_}; }
  // R_y(α)·d: the world direction of the image's direction d.
  Vec3 to_world(const Vec3& d) const { return {d.x * cos_ + d.z * sin_, d.y, -d.x * sin_ + d.z * cos_}; }

 private:
  double cos_ = 1.0, sin_ = 0.0;
};

}  // namespace kiln::envmap
