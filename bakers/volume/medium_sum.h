// Several media as one: where they overlap their coefficients add (sigma_a, sigma_s, and the emission weighted by
// absorption, sigma_a·Le = Σ sigma_a_i·Le_i), and the phase function at a point is the mixture of the media's
// Henyey–Greenstein lobes weighted by their sigma_s there (phase_mixture.h). Its majorant along a ray is one segment
// over the part of the ray inside any medium's bounds, bounded by the sum of each medium's largest majorant along
// that ray: exact, but it gives up the empty-space skipping of a single grid medium, so a bake with one medium
// tracks that medium directly.
#pragma once

#include <vector>

#include "bakers/volume/medium.h"

namespace kiln::volume {

class MediumSum final : public Medium {
 public:
  // The media must outlive this.
  explicit MediumSum(std::vector<const Medium*> media);

  MediumProperties at(const Vec3& p) const override;
  MajorantIterator majorants(const scene::Ray& ray, double t_end) const override;
  // The sigma_s-weighted mean of the media's g; the transport samples the mixture instead (phase_mixture.h).
  double g() const override { return g_; }
  Bounds3 bounds() const override { return bounds_; }

  const std::vector<const Medium*>& media() const { return media_; }

 private:
  std::vector<const Medium*> media_;
  Bounds3 bounds_;
  double g_ = 0;
};

}  // namespace kiln::volume
