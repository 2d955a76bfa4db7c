#include "bakers/volume/ray_box.h"

#include <algorithm>
#include <utility>

namespace kiln::volume {

bool clip_ray_to_box(const Vec3& origin, const Vec3& direction, const Vec3& lo, const Vec3& hi, double& t0,
                     double& t1) {
  for (int a = 0; a < 3; ++a) {
    const double o = axis(origin, a), d = axis(direction, a), l = axis(lo, a), h = axis(hi, a);
    // Parallel to this slab (the divisions below would give ±inf or NaN): inside for every t or for none.
    if (d == 0.0) {
      if (o < l || o > h) return false;
      continue;
    }
    double near = (l - o) / d, far = (h - o) / d;
    if (near > far) std::swap(near, far);
    t0 = std::max(t0, near);
    t1 = std::min(t1, far);
  }
  return t0 < t1;
}

}  // namespace kiln::volume
