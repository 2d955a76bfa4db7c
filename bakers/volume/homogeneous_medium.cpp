#include "bakers/volume/homogeneous_medium.h"

#include <algorithm>
#include <cmath>

#include "bakers/bake/range_check.h"
#include "bakers/volume/medium_bounds.h"
#include "bakers/volume/ray_box.h"

namespace kiln::volume {

namespace {

void validate(const HomogeneousMediumSpec& s) {
  if (auto e = bake::check_rgb("sigma_a", s.sigma_a, limits::kMediumCoefficient)) throw *e;
  if (auto e = bake::check_rgb("sigma_s", s.sigma_s, limits::kMediumCoefficient)) throw *e;
  if (auto e = bake::check_rgb("Le", s.Le, limits::kMediumEmission)) throw *e;
  if (auto e = bake::check_range("g", s.g, limits::kMediumAsymmetry)) throw *e;
  if (s.box && (!is_finite(s.box->lo) || !is_finite(s.box->hi) || s.box->empty()))
    throw bake::InvalidInput("box", "must have finite corners with lo ≤ hi on every axis");
}

}  // namespace

HomogeneousMedium::HomogeneousMedium(const HomogeneousMediumSpec& spec) : spec_(spec) { validate(spec_); }

bool HomogeneousMedium::inside(const Vec3& p) const {
  if (!spec_.box) return true;
  const Bounds3& b = *spec_.box;
  return p.x >= b.lo.x && p.x <= b.hi.x && p.y >= b.lo.y && p.y <= b.hi.y && p.z >= b.lo.z && p.z <= b.hi.z;
}

MediumProperties HomogeneousMedium::at(const Vec3& p) const {
  if (!inside(p)) return {};
  return {spec_.sigma_a, spec_.sigma_s, spec_.Le};
}

MajorantIterator HomogeneousMedium::majorants(const scene::Ray& ray, double t_end) const {
  double t0 = 0, t1 = t_end;
  if (spec_.box && !clip_ray_to_box(ray.origin, ray.direction, spec_.box->lo, spec_.box->hi, t0, t1)) return {};
  return MajorantIterator::single(t0, t1, spec_.sigma_a + spec_.sigma_s);
}

Bounds3 HomogeneousMedium::bounds() const {
  if (spec_.box) return *spec_.box;
  return {{-INFINITY, -INFINITY, -INFINITY}, {INFINITY, INFINITY, INFINITY}};
}

}  // namespace kiln::volume
