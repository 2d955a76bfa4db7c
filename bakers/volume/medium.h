// A participating medium (pbrt-v4's Medium interface, Pharr, Jakob & Humphreys 2023, §11.4): absorption sigma_a and
// scattering sigma_s per RGB channel at a point, emitted radiance Le, the Henyey–Greenstein asymmetry g, and the
// majorants sigma_maj ≥ sigma_t = sigma_a + sigma_s along a ray, piecewise constant, that the tracking estimators
// (tracking.h) sample against. Coefficients are per unit of the world's length (m⁻¹ with scenes in metres).
//
// Rays are in world space; t is in units of |direction| (scene::Ray), the same parameter along the whole chain of
// transforms, so a majorant segment [t_min, t_max) means the same stretch of the ray in every space.
#pragma once

#include "bakers/math/rgb.h"
#include "bakers/math/vec3.h"
#include "bakers/scene/ray_offset.h"
#include "bakers/volume/majorant_iterator.h"

namespace kiln::volume {

// What the medium is at one point.
struct MediumProperties {
  Rgb sigma_a;  // absorption coefficient
  Rgb sigma_s;  // scattering coefficient
  Rgb Le;       // emitted radiance (W·m⁻²·sr⁻¹), weighted by sigma_a where it is collected
  Rgb sigma_t() const { return sigma_a + sigma_s; }
};

// An axis-aligned box in world space.
struct Bounds3 {
  Vec3 lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
  bool empty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
  bool overlaps(const Bounds3& o) const {
    return !empty() && !o.empty() && lo.x <= o.hi.x && o.lo.x <= hi.x && lo.y <= o.hi.y && o.lo.y <= hi.y &&
           lo.z <= o.hi.z && o.lo.z <= hi.z;
  }
};

class Medium {
 public:
  virtual ~Medium() = default;
  // The coefficients at world point p (zero outside the medium's support).
  virtual MediumProperties at(const Vec3& p) const = 0;
  // The majorant segments of the ray over [0, t_end), in increasing t; gaps between segments have sigma_maj = 0.
  virtual MajorantIterator majorants(const scene::Ray& ray, double t_end) const = 0;
  // The Henyey–Greenstein asymmetry g of the medium's phase function, in (−1, 1).
  virtual double g() const = 0;
  // World-space bounds of the medium's support; unbounded (fog filling the scene) is ±infinity.
  virtual Bounds3 bounds() const = 0;
};

}  // namespace kiln::volume
