#include "bakers/scene/ray_offset.h"

#include <algorithm>
#include <cmath>

namespace kiln::scene {
namespace {

// Unit roundoff of float and Higham's γ_k = kε / (1 − kε), the bound on the relative error of k float operations.
constexpr double kEps = 0x1.0p-24;
constexpr double gamma(int k) { return k * kEps / (1 - k * kEps); }

double max_abs(const Vec3& v) { return std::max({std::fabs(v.x), std::fabs(v.y), std::fabs(v.z)}); }

}  // namespace

// Why this bound. Embree's triangle tests (Möller–Trumbore, and the Plücker test of robust mode) both decide the hit
// distance from T = Ng·(v0 − O) with Ng = (v1 − v0) × (v2 − v0), all in float, and accept the triangle when T/den >
// tnear = 0, den = Ng·D. Let O be h above the triangle's plane on the side the ray travels to: the exact T then has
// the sign of a hit *behind* the origin, |T| = |Ng|·h, and the test can only accept it if the rounding error of T
// exceeds |Ng|·h. First-order error terms (ε = 2^-24, γ_k as above, ℓ the longest edge, so |e1|,|e2| ≤ ℓ, and
// |v0 − O| ≤ ℓ + h):
//   edges and cross product, incl. rounding the edges:  |ΔNg| ≤ √3·γ_3·ℓ²
//   C = v0 − O rounded:                                |ΔC|  ≤ ε·|C|
//   the dot product of three terms:                    γ_3·|Ng|·|C|
// so |ΔT| ≤ |C|·(√3·γ_3·ℓ² + γ_4·|Ng|), and T keeps its sign when h > ℓ·k / (1 − k) with k = √3·γ_3·ℓ²/|Ng| + γ_4.
// ℓ²/|Ng| is 1/sin of the triangle's smallest angle (up to a factor ≤ 2): slivers need more lift, well-shaped
// triangles ~10ε of their size. This term does not grow with the distance from the origin because Embree subtracts
// float vertices from a float origin; the origin itself is lifted by the most that rounding it to float can take
// back before it is rounded (offset_ray_origin), so it keeps the whole lift. The hit point p is interpolated in
// double from the float vertices, so it lies on their plane to ~1e-16 relative: no term for it.
// Coplanar neighbours: world vertices are rounded to float one by one (by up to ε·|v| per coordinate), so a triangle
// that shared the hit triangle's plane before rounding can stand up to √3·ε·m above it near their shared edge, m the
// largest coordinate magnitude; the second term lifts the origin over it.
// Both terms are doubled to absorb the second-order terms dropped above and Embree's choice of which vertex is v0.
double self_intersection_offset(const Vec3& v0, const Vec3& v1, const Vec3& v2, const Vec3& p) {
  const double longest = std::max({length(v1 - v0), length(v2 - v1), length(v0 - v2)});
  const double area2 = length(cross(v1 - v0, v2 - v0));
  const double m = std::max({max_abs(v0), max_abs(v1), max_abs(v2), max_abs(p)});
  const double neighbours = std::sqrt(3.0) * kEps * m;
  // A triangle of zero area cannot be hit (den = 0): nothing to clear but the neighbours. scene_check drops such
  // triangles; this guards a collapse by an instance transform.
  if (!(area2 > 0)) return 2 * neighbours;
  const double k = std::sqrt(3.0) * gamma(3) * longest * longest / area2 + gamma(4);
  // k ≥ 1 only for a triangle flatter than ~1e-7 (sin of its angle below γ_3): lift by its whole size then.
  const double self = k < 0.5 ? longest * k / (1 - k) : longest;
  return 2 * (self + neighbours);
}

}  // namespace kiln::scene
