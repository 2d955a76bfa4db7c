#include "bakers/volume/medium_sum.h"

#include <algorithm>

namespace kiln::volume {

MediumSum::MediumSum(std::vector<const Medium*> media) : media_(std::move(media)) {
  double weight = 0, weighted_g = 0;
  for (const Medium* m : media_) {
    const Bounds3 b = m->bounds();
    bounds_.lo = {std::min(bounds_.lo.x, b.lo.x), std::min(bounds_.lo.y, b.lo.y), std::min(bounds_.lo.z, b.lo.z)};
    bounds_.hi = {std::max(bounds_.hi.x, b.hi.x), std::max(bounds_.hi.y, b.hi.y), std::max(bounds_.hi.z, b.hi.z)};
    const double s = m->at((b.lo + b.hi) * 0.5).sigma_s.max();
    weight += s;
    weighted_g += s * m->g();
  }
  g_ = weight > 0 ? weighted_g / weight : 0.0;
}

MediumProperties MediumSum::at(const Vec3& p) const {
  MediumProperties sum;
  Rgb emitted;  // Σ sigma_a_i·Le_i
  for (const Medium* m : media_) {
    const MediumProperties mp = m->at(p);
    sum.sigma_a += mp.sigma_a;
    sum.sigma_s += mp.sigma_s;
    emitted += mp.sigma_a * mp.Le;
  }
  // Le such that sigma_a·Le is the sum; a channel without absorption collects no emission whatever Le is.
  auto share = [](double e, double a) { return a > 0 ? e / a : 0.0; };
  sum.Le = {share(emitted.r, sum.sigma_a.r), share(emitted.g, sum.sigma_a.g), share(emitted.b, sum.sigma_a.b)};
  return sum;
}

MajorantIterator MediumSum::majorants(const scene::Ray& ray, double t_end) const {
  Rgb sigma_maj;
  double t_min = t_end, t_max = 0;
  for (const Medium* m : media_) {
    Rgb largest;
    MajorantIterator segments = m->majorants(ray, t_end);
    while (const auto s = segments.next()) {
      if (s->sigma_maj.max() == 0) continue;  // empty space adds nothing
      largest = {std::max(largest.r, s->sigma_maj.r), std::max(largest.g, s->sigma_maj.g),
                 std::max(largest.b, s->sigma_maj.b)};
      t_min = std::min(t_min, s->t_min);
      t_max = std::max(t_max, s->t_max);
    }
    sigma_maj += largest;
  }
  if (!(t_min < t_max)) return {};
  return MajorantIterator::single(t_min, t_max, sigma_maj);
}

}  // namespace kiln::volume
