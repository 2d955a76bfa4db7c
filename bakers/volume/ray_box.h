// The stretch of a ray inside an axis-aligned box (the slab test, Kay & Kajiya 1986).
#pragma once

#include "bakers/math/vec3.h"

namespace kiln::volume {

// Coordinate a (0: x, 1: y, 2: z) of v, for loops over the axes.
inline double axis(const Vec3& v, int a) { return a == 0 ? v.x : (a == 1 ? v.y : v.z); }

// Narrows [t0, t1] to the ray origin + t·direction's stretch inside the box [lo, hi]; false if nothing is left.
// The direction need not be unit. An axis the ray runs parallel to keeps the whole interval or empties it.
bool clip_ray_to_box(const Vec3& origin, const Vec3& direction, const Vec3& lo, const Vec3& hi, double& t0, double& t1);

}  // namespace kiln::volume
