// A medium of the same coefficients everywhere in a world-space box, or everywhere (fog filling the scene).
#pragma once

#include <optional>

#include "bakers/volume/medium.h"

namespace kiln::volume {

struct HomogeneousMediumSpec {
  Rgb sigma_a;                 // m⁻¹, ≥ 0 and finite
  Rgb sigma_s;                 // m⁻¹, ≥ 0 and finite
  Rgb Le;                      // emitted radiance, ≥ 0 and finite
  double g = 0;                // Henyey–Greenstein asymmetry, in (−1, 1)
  std::optional<Bounds3> box;  // absent: the whole scene
};

class HomogeneousMedium final : public Medium {
 public:
  // Throws bake::InvalidInput naming the field ("sigma_a", "g", "box") for values out of range, a NaN, or a box
  // with lo > hi.
  explicit HomogeneousMedium(const HomogeneousMediumSpec& spec);

  MediumProperties at(const Vec3& p) const override;
  MajorantIterator majorants(const scene::Ray& ray, double t_end) const override;
  double g() const override { return spec_.g; }
  Bounds3 bounds() const override;

 private:
  bool inside(const Vec3& p) const;

  HomogeneousMediumSpec spec_;
};

}  // namespace kiln::volume
