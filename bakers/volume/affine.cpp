#include "bakers/volume/affine.h"

#include "bakers/scene/scene_check.h"

namespace kiln::volume {

scene::Transform from_columns(const Vec3& x, const Vec3& y, const Vec3& z, const Vec3& origin) {
  scene::Transform t;
  t.m = {x.x, y.x, z.x, origin.x, x.y, y.y, z.y, origin.y, x.z, y.z, z.z, origin.z};
  return t;
}

scene::Transform compose(const scene::Transform& a, const scene::Transform& b) {
  const Vec3 x = a.vector(b.vector({1, 0, 0})), y = a.vector(b.vector({0, 1, 0})), z = a.vector(b.vector({0, 0, 1}));
  return from_columns(x, y, z, a.point(b.point({0, 0, 0})));
}

std::optional<scene::Transform> inverse(const scene::Transform& t) {
  if (!scene::usable_transform(t)) return std::nullopt;
  const Vec3 c0{t.m[0], t.m[4], t.m[8]}, c1{t.m[1], t.m[5], t.m[9]}, c2{t.m[2], t.m[6], t.m[10]};
  // The inverse of M = [c0 c1 c2] has rows (c1 × c2, c2 × c0, c0 × c1) / det.
  const double det = dot(c0, cross(c1, c2));
  const Vec3 r0 = cross(c1, c2) / det, r1 = cross(c2, c0) / det, r2 = cross(c0, c1) / det;
  const Vec3 o{t.m[3], t.m[7], t.m[11]};
  scene::Transform inv;
  inv.m = {r0.x, r0.y, r0.z, -dot(r0, o), r1.x, r1.y, r1.z, -dot(r1, o), r2.x, r2.y, r2.z, -dot(r2, o)};
  return inv;
}

}  // namespace kiln::volume
