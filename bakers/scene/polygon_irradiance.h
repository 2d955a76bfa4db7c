// The exact irradiance from a uniformly emitting polygon (Lambert 1760; Arvo 1994, "The irradiance Jacobian for
// partially occluded polyhedral sources", eq. 5): the projected solid angle of a planar polygon seen from p with
// unit normal n,
//     ∫_polygon max(0, n·ω) dω = ½ |Σ_i Θ_i (n · γ̂_i)|,   Θ_i = ∠(v_i, v_{i+1}),  γ̂_i = (v_i × v_{i+1}) / |…|,
// with v_i = x_i − p. The formula holds for a polygon above p's horizon; the polygon is clipped to the half-space
// n·(x − p) ≥ 0 first (Sutherland–Hodgman), so any polygon works. Irradiance from radiance L is E = L × this value.
// A reference for tests of the lights and the lightmap baker: no sampling, no tolerance beyond rounding.
#pragma once

#include <vector>

#include "bakers/math/vec3.h"

namespace kiln::scene {

// Vertices in order around the polygon (either winding; convex or not, but planar and simple). Edges through p
// itself (p on the polygon's boundary) contribute nothing (their Θ_i γ̂_i has no direction); degenerate polygons give 0.
double polygon_projected_solid_angle(const std::vector<Vec3>& polygon, const Vec3& p, const Vec3& n);

// The polygon's part in the half-space n·(x − p) ≥ 0.
std::vector<Vec3> clip_polygon_to_half_space(const std::vector<Vec3>& polygon, const Vec3& p, const Vec3& n);

}  // namespace kiln::scene
