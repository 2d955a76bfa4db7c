// Rays, and spawning them off surfaces without self-intersection at any scene scale.
//
// The tracer (tracer.h) intersects in single precision with tnear = 0. A ray leaving a surface therefore starts at a
// point lifted off the surface's plane by `offset` along the geometric normal (on the side the ray leaves to), and by
// as much again as rounding the origin to float can take back. `offset` bounds the float error of
// the ray–triangle test itself (see self_intersection_offset); it scales with the triangle and with the magnitude of
// the coordinates, never with a fixed epsilon, so a scene scaled by 1e-3 or 1e4, or far from the origin, behaves the
// same.
#pragma once

#include <cmath>

#include "bakers/math/vec3.h"

namespace kiln::scene {

// origin + t·direction for t in (0, tmax]. The direction need not be unit: t is in units of |direction|. Origins
// made by the spawn functions below are exactly representable in float (the tracer passes them to Embree unrounded).
struct Ray {
  Vec3 origin;
  Vec3 direction;
  double tmax = INFINITY;
};

// How far a ray origin at p is lifted along the unit normal ±ng: `offset`, and as much again as rounding the lifted
// point to the nearest float can take back. Rounding moves each coordinate o_i by at most half an ulp, 2^-24·|o_i|
// (2^-150 below the normal range), so the point can sink back towards the surface by at most
// Σ|n_i|·(2^-24·|o_i| + 2^-150) ≤ 2^-24·(Σ|n_i·p_i| + lift) + √3·2^-150 along n: the lift includes that much more (the
// factor 1 + 2^-20 covers the allowance's own share of the lift), so the float origin stands at least `offset` off
// the surface. Weighting by |n_i| matters: only the coordinates the normal points along can take the lift back (a
// floor far from the origin in x and z loses nothing to their rounding). The same on either side of the surface.
// (Rounding each coordinate away from the surface instead needs two comparisons and a bit step per coordinate, and
// the side each nearest float falls on is a coin toss: mispredicted half the time on every ray.)
inline double origin_lift(const Vec3& p, const Vec3& ng, double offset) {
  const double along = std::fabs(ng.x * p.x) + std::fabs(ng.y * p.y) + std::fabs(ng.z * p.z);
  return offset + (0x1.00001p-24 * (along + std::fabs(offset)) + 0x1.0p-149);
}

// A point on a surface as a ray leaves it: the unit geometric normal (either side) and the distance along it that
// clears the surface's float error (Hit::offset). Its lift (origin_lift) is computed once, when it is made: every
// ray leaving the point (a shadow ray and the next bounce at a path vertex) shares it. Flipping ng keeps it valid;
// p and offset are set through the constructor.
struct SurfacePoint {
  Vec3 p;
  Vec3 ng;
  double offset = 0;
  double lift = 0;  // origin_lift(p, ng, offset)

  SurfacePoint() = default;
  SurfacePoint(const Vec3& p_, const Vec3& ng_, double offset_)
      : p(p_), ng(ng_), offset(offset_), lift(origin_lift(p_, ng_, offset_)) {}
};

// The distance along the normal a ray origin must be lifted off triangle (v0, v1, v2) at its point p so that a float
// ray–triangle test with tnear = 0 cannot find the triangle again (nor a coplanar neighbour whose vertices were
// rounded to float separately). The vertices are the float values the tracer holds (exact in double); p is on their
// plane (barycentric interpolation in double). The derivation is in ray_offset.cpp. For a well-shaped triangle it is
// ~1e-6 of the triangle's size plus ~7e-7 of the largest coordinate magnitude.
double self_intersection_offset(const Vec3& v0, const Vec3& v1, const Vec3& v2, const Vec3& p);

// s.p lifted by s.lift along n (s.ng or −s.ng), then rounded to the nearest float: at least s.offset off the surface
// (origin_lift). Inline with the spawn functions below: they run for every ray a bake traces.
[[gnu::always_inline]] inline Vec3 lifted_origin(const SurfacePoint& s, const Vec3& n) {
  const Vec3 o = s.p + n * s.lift;
  return {static_cast<float>(o.x), static_cast<float>(o.y), static_cast<float>(o.z)};
}
// The origin of a ray leaving s in direction w: lifted to the side w leaves to.
[[gnu::always_inline]] inline Vec3 offset_ray_origin(const SurfacePoint& s, const Vec3& w) {
  return lifted_origin(s, dot(w, s.ng) < 0 ? -s.ng : s.ng);
}
// The same for a ray the caller knows leaves on ng's side (it has tested dot(w, s.ng) > 0, as transport does before
// every ray it spawns): no second test.
[[gnu::always_inline]] inline Vec3 offset_ray_origin_front(const SurfacePoint& s) { return lifted_origin(s, s.ng); }

// A ray leaving s in direction w.
[[gnu::always_inline]] inline Ray spawn_ray(const SurfacePoint& s, const Vec3& w, double tmax = INFINITY) {
  return {offset_ray_origin(s, w), w, tmax};
}
// The same for dot(w, s.ng) > 0, tested by the caller.
[[gnu::always_inline]] inline Ray spawn_ray_front(const SurfacePoint& s, const Vec3& w, double tmax = INFINITY) {
  return {offset_ray_origin_front(s), w, tmax};
}

// A shadow ray from s towards a point (a point light, a sample on an area light that is not scene geometry): the
// direction is target − origin and tmax stops kShadowEpsilon short of the target, so nothing at the target counts.
inline constexpr double kShadowEpsilon = 1e-4;
[[gnu::always_inline]] inline Ray shadow_ray(const Vec3& origin, const Vec3& target) {
  return {origin, target - origin, 1 - kShadowEpsilon};
}
[[gnu::always_inline]] inline Ray spawn_ray_to(const SurfacePoint& from, const Vec3& target) {
  return shadow_ray(offset_ray_origin(from, target - from.p), target);
}
// The same for a target on ng's side (dot(target − from.p, from.ng) > 0), tested by the caller.
[[gnu::always_inline]] inline Ray spawn_ray_to_front(const SurfacePoint& from, const Vec3& target) {
  return shadow_ray(offset_ray_origin_front(from), target);
}
// The same towards a point on a scene surface (an emissive triangle), itself lifted off its surface towards `from`.
inline Ray spawn_ray_to(const SurfacePoint& from, const SurfacePoint& to) {
  return shadow_ray(offset_ray_origin(from, to.p - from.p), offset_ray_origin(to, from.p - to.p));
}

}  // namespace kiln::scene
