// Solid angles and angles between directions, computed without the cancellation of the textbook formulas: the
// area lights use them for their densities, the tests for references.
#pragma once

#include <cmath>

#include "bakers/math/constants.h"
#include "bakers/math/vec3.h"

namespace kiln::scene {

// The angle between unit vectors a and b, accurate near 0 and π (2 asin of half the chord, not acos of the dot).
inline double angle_between(const Vec3& a, const Vec3& b) {
  if (dot(a, b) < 0) return kPi - 2.0 * std::asin(std::fmin(1.0, length(a + b) / 2.0));
  return 2.0 * std::asin(std::fmin(1.0, length(b - a) / 2.0));
}

// The solid angle of the triangle (a, b, c) seen from the origin (Van Oosterom & Strackee 1983):
//   tan(Ω/2) = |a·(b×c)| / (|a||b||c| + (a·b)|c| + (a·c)|b| + (b·c)|a|),
// with atan2 so that Ω > π (denominator < 0) comes out right. Accurate for tiny triangles, where Girard's
// angle-excess formula cancels. A vertex at the origin: 0.
inline double triangle_solid_angle(const Vec3& a, const Vec3& b, const Vec3& c) {
  const double la = length(a), lb = length(b), lc = length(c);
  if (!(la > 0 && lb > 0 && lc > 0)) return 0.0;
  const double num = std::fabs(dot(a, cross(b, c)));
  const double den = la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la;
  return 2.0 * std::atan2(num, den);
}

}  // namespace kiln::scene
