#include "bakers/scene/polygon_irradiance.h"

#include <cmath>

#include "bakers/scene/spherical_geometry.h"

namespace kiln::scene {

std::vector<Vec3> clip_polygon_to_half_space(const std::vector<Vec3>& polygon, const Vec3& p, const Vec3& n) {
  std::vector<Vec3> out;
  const size_t m = polygon.size();
  for (size_t i = 0; i < m; ++i) {
    const Vec3& a = polygon[i];
    const Vec3& b = polygon[(i + 1) % m];
    const double da = dot(a - p, n), db = dot(b - p, n);
    if (da >= 0) out.push_back(a);
    // The edge crosses the plane strictly: add the crossing (da − db ≠ 0 there, so the division is safe).
    if ((da > 0 && db < 0) || (da < 0 && db > 0)) out.push_back(a + (b - a) * (da / (da - db)));
  }
  return out;
}

double polygon_projected_solid_angle(const std::vector<Vec3>& polygon, const Vec3& p, const Vec3& n) {
  const std::vector<Vec3> clipped = clip_polygon_to_half_space(polygon, p, n);
  const size_t m = clipped.size();
  if (m < 3) return 0.0;
  double sum = 0;
  for (size_t i = 0; i < m; ++i) {
    const Vec3 a = clipped[i] - p, b = clipped[(i + 1) % m] - p;
    const Vec3 g = cross(a, b);
    const double lg = length(g), la = length(a), lb = length(b);
    // A vertex at p, or an edge whose line passes through p: Θ_i γ̂_i is 0 (or has no direction); no contribution.
    if (!(lg > 0 && la > 0 && lb > 0)) continue;
    sum += angle_between(a / la, b / lb) * dot(n, g / lg);
  }
  return 0.5 * std::fabs(sum);
}

}  // namespace kiln::scene
