// Warping uniform samples on [0,1)^2 to directions, each with the density it produces (per solid angle).
#pragma once

#include <cmath>

#include "bakers/math/constants.h"
#include "bakers/math/vec3.h"

namespace kiln {

struct Point2 {
  double x = 0, y = 0;
};

// Shirley–Chiu concentric map from the square to the unit disk: area-preserving and continuous.
inline Point2 sample_concentric_disk(Point2 u) {
  const double ox = 2.0 * u.x - 1.0, oy = 2.0 * u.y - 1.0;
  // The centre of the square maps to the centre of the disk; the formulas below divide by ox or oy.
  if (ox == 0.0 && oy == 0.0) return {0.0, 0.0};
  double r, theta;
  if (std::fabs(ox) > std::fabs(oy)) {
    r = ox;
    theta = kPiOver4 * (oy / ox);
  } else {
    r = oy;
    theta = kPiOver2 - kPiOver4 * (ox / oy);
  }
  return {r * std::cos(theta), r * std::sin(theta)};
}

// Cosine-weighted hemisphere around +z (Malley's method); pdf = cos θ / π.
inline Vec3 sample_cosine_hemisphere(Point2 u) {
  const Point2 d = sample_concentric_disk(u);
  const double z = std::sqrt(std::fmax(0.0, 1.0 - d.x * d.x - d.y * d.y));
  return {d.x, d.y, z};
}
// The same density by Malley's method from a point uniform on the disk found by rejection from the square (accepted
// with probability π/4): no trigonometry, for hot loops that draw independent random numbers. The map from random
// numbers is not continuous and their count varies, so it does not carry stratification over; the Point2 overload
// does. Each coordinate takes 32 random bits (rng.next_u32()): a direction needs no more (a float has 24), and the
// loop draws half as many numbers as with 53-bit uniforms.
template <class Rng>
[[gnu::always_inline]] inline Vec3 sample_cosine_hemisphere(Rng& rng) {
  for (;;) {
    // k·2^-31 − 1 for k in [0, 2^32): exact in double, in [−1, 1).
    const double x = rng.next_u32() * 0x1.0p-31 - 1.0, y = rng.next_u32() * 0x1.0p-31 - 1.0;
    const double r2 = x * x + y * y;
    if (r2 < 1.0) return {x, y, std::sqrt(1.0 - r2)};
  }
}
inline double cosine_hemisphere_pdf(double cos_theta) { return cos_theta > 0 ? cos_theta * kInvPi : 0.0; }

inline Vec3 sample_uniform_hemisphere(Point2 u) {
  const double z = u.x;
  const double r = std::sqrt(std::fmax(0.0, 1.0 - z * z));
  const double phi = 2.0 * kPi * u.y;
  return {r * std::cos(phi), r * std::sin(phi), z};
}
inline double uniform_hemisphere_pdf() { return kInv2Pi; }

inline Vec3 sample_uniform_sphere(Point2 u) {
  const double z = 1.0 - 2.0 * u.x;
  const double r = std::sqrt(std::fmax(0.0, 1.0 - z * z));
  const double phi = 2.0 * kPi * u.y;
  return {r * std::cos(phi), r * std::sin(phi), z};
}
inline double uniform_sphere_pdf() { return kInv4Pi; }

// Reflection of wo about the unit vector n (both pointing away from the surface).
inline Vec3 reflect(const Vec3& wo, const Vec3& n) { return -wo + n * (2.0 * dot(wo, n)); }

}  // namespace kiln
