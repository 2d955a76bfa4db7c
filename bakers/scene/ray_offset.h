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
// The next float above / below a finite float, by stepping its bit pattern (what nextafterf does, without the
// library call on every ray origin). −0 and +0 both step to the smallest denormal of the sign asked for.
inline float next_float_up(float f) {
  if (f == 0.0f) return std::numeric_limits<float>::denorm_min();
  const uint32_t bits = std::bit_cast<uint32_t>(f);
  return std::bit_cast<float>(f > 0 ? bits + 1 : bits - 1);
}
inline float next_float_down(float f) { return -next_float_up(-f); }

// Rounds x to a float on the side `direction` points to (x itself if it is a float already). Origins are finite
// floats well inside the range (the tracer refuses scenes beyond it), so the steps never reach an infinity.
inline double round_float_towards(double x, double direction) {
  const float f = static_cast<float>(x);
  if (direction > 0 && static_cast<double>(f) < x) return next_float_up(f);
  if (direction < 0 && static_cast<double>(f) > x) return next_float_down(f);
  return f;
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
inline Ray spawn_ray(const SurfacePoint& s, const Vec3& w, double tmax = INFINITY) {
  return {offset_ray_origin(s, w), w, tmax};
}

// A shadow ray from s towards a point (a point light, a sample on an area light that is not scene geometry): the
// direction is target − origin and tmax stops kShadowEpsilon short of the target, so nothing at the target counts.
inline constexpr double kShadowEpsilon = 1e-4;
inline Ray spawn_ray_to(const SurfacePoint& from, const Vec3& target) {
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
