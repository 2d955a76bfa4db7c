// Rays, and spawning them off surfaces without self-intersection at any scene scale.
//
// The tracer (tracer.h) intersects in single precision with tnear = 0. A ray leaving a surface therefore starts at a
// point lifted off the surface's plane by `offset` along the geometric normal (on the side the ray leaves to), with
// the origin rounded to float *away from* the surface, component by component. `offset` bounds the float error of
// the ray–triangle test itself (see self_intersection_offset); it scales with the triangle and with the magnitude of
// the coordinates, never with a fixed epsilon, so a scene scaled by 1e-3 or 1e4, or far from the origin, behaves the
// same.
#pragma once

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>

#include "bakers/math/vec3.h"

namespace kiln::scene {

// origin + t·direction for t in (0, tmax]. The direction need not be unit: t is in units of |direction|. Origins
// made by the spawn functions below are exactly representable in float (the tracer passes them to Embree unrounded).
struct Ray {
  Vec3 origin;
  Vec3 direction;
  double tmax = INFINITY;
};

// A point on a surface as a ray leaves it: the unit geometric normal (either side) and the distance along it that
// clears the surface's float error (Hit::offset).
struct SurfacePoint {
  Vec3 p;
  Vec3 ng;
  double offset = 0;
};

// The distance along the normal a ray origin must be lifted off triangle (v0, v1, v2) at its point p so that a float
// ray–triangle test with tnear = 0 cannot find the triangle again (nor a coplanar neighbour whose vertices were
// rounded to float separately). The vertices are the float values the tracer holds (exact in double); p is on their
// plane (barycentric interpolation in double). The derivation is in ray_offset.cpp. For a well-shaped triangle it is
// ~1e-6 of the triangle's size plus ~7e-7 of the largest coordinate magnitude.
double self_intersection_offset(const Vec3& v0, const Vec3& v1, const Vec3& v2, const Vec3& p);

namespace detail {
// Rounds x to a float on the side `direction` points to (x itself if it is a float already; any float when
// direction is 0), by stepping the bit pattern of the nearest float, as nextafterf would, without branches: which
// side the nearest float falls on is a coin toss for every coordinate of every ray origin, and a branch on it was
// mispredicted half the time. Origins are finite floats well inside the range (the tracer refuses scenes beyond
// it), so the steps never reach an infinity.
inline double round_float_towards(double x, double direction) {
  const float f = static_cast<float>(x);
  const int up = direction > 0 && static_cast<double>(f) < x;
  const int down = direction < 0 && static_cast<double>(f) > x;
  uint32_t bits = std::bit_cast<uint32_t>(f);
  // ±0 steps to the smallest denormal of the sign asked for: start from the zero of that sign (a zero that does not
  // step keeps its own).
  bits = f == 0.0f && (up | down) ? static_cast<uint32_t>(down) << 31 : bits;
  const int negative = static_cast<int>(bits >> 31);
  // In the bit pattern, +1 moves away from zero and −1 towards it; up moves away from zero for positive floats.
  const int step = (up - down) * (1 - 2 * negative);
  return std::bit_cast<float>(bits + static_cast<uint32_t>(step));
}
}  // namespace detail

// s.p lifted by s.offset along ±s.ng (the side w leaves to), rounded to float away from the surface. (Inline with
// the spawn functions below: they run for every ray a bake traces.)
[[gnu::always_inline]] inline Vec3 offset_ray_origin(const SurfacePoint& s, const Vec3& w) {
  const Vec3 n = dot(w, s.ng) < 0 ? -s.ng : s.ng;
  const Vec3 o = s.p + n * s.offset;
  return {detail::round_float_towards(o.x, n.x), detail::round_float_towards(o.y, n.y),
          detail::round_float_towards(o.z, n.z)};
}

// A ray leaving s in direction w.
[[gnu::always_inline]] inline Ray spawn_ray(const SurfacePoint& s, const Vec3& w, double tmax = INFINITY) {
  return {offset_ray_origin(s, w), w, tmax};
}

// A shadow ray from s towards a point (a point light, a sample on an area light that is not scene geometry): the
// direction is target − origin and tmax stops kShadowEpsilon short of the target, so nothing at the target counts.
inline constexpr double kShadowEpsilon = 1e-4;
[[gnu::always_inline]] inline Ray spawn_ray_to(const SurfacePoint& from, const Vec3& target) {
  const Vec3 origin = offset_ray_origin(from, target - from.p);
  return {origin, target - origin, 1 - kShadowEpsilon};
}
// The same towards a point on a scene surface (an emissive triangle), itself lifted off its surface towards `from`.
inline Ray spawn_ray_to(const SurfacePoint& from, const SurfacePoint& to) {
  const Vec3 origin = offset_ray_origin(from, to.p - from.p);
  const Vec3 target = offset_ray_origin(to, from.p - to.p);
  return {origin, target - origin, 1 - kShadowEpsilon};
}

}  // namespace kiln::scene
