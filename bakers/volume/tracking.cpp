#include "bakers/volume/tracking.h"

#include <algorithm>

namespace kiln::volume {

namespace {

// sigma_n = σ̄ − sigma_t per channel. A trilinear lookup is a convex combination of values the majorant bounds, but
// its rounding can exceed the bound by an ulp: such a channel counts as having no null coefficient.
Rgb null_coefficient(double sigma_bar, const Rgb& sigma_t) {
  return {std::max(0.0, sigma_bar - sigma_t.r), std::max(0.0, sigma_bar - sigma_t.g),
          std::max(0.0, sigma_bar - sigma_t.b)};
}

// Ratio tracking's Russian roulette (pbrt-v4's, §14.2.2): once no channel of the estimate exceeds kRouletteBelow,
// the walk ends with probability kRouletteKill and otherwise continues with its estimate divided by 1 −
// kRouletteKill: unbiased, and it ends walks through long optically thick stretches that could add nothing visible.
constexpr double kRouletteBelow = 0.05;
constexpr double kRouletteKill = 0.75;

// One collision of spectral tracking: updates f, returns true for a null collision (the walk goes on).
bool collide(FreeFlight& f, const MediumProperties& mp, double sigma_bar, double u) {
  const Rgb sigma_n = null_coefficient(sigma_bar, mp.sigma_t());
  const double ca = (f.weight * mp.sigma_a).max(), cs = (f.weight * mp.sigma_s).max(), cn = (f.weight * sigma_n).max();
  const double c = ca + cs + cn;
  // Every channel's weight is zero: the estimate is 0 whatever happens next.
  if (!(c > 0)) return f.event = FlightEvent::absorbed, f.weight = Rgb(0), false;
  const double x = u * c;
  if (x < ca) return f.event = FlightEvent::absorbed, f.weight = Rgb(0), false;
  if (x < ca + cs) {
    f.event = FlightEvent::scattered;
    f.weight = f.weight * mp.sigma_s * (c / (sigma_bar * cs));
    return false;
  }
  f.weight = f.weight * sigma_n * (c / (sigma_bar * cn));
  return true;
}

}  // namespace

FreeFlight sample_free_flight(const Medium& medium, const scene::Ray& ray, double t_end, Pcg32& rng) {
  FreeFlight f;
  f.t = t_end;
  track_majorants(medium, ray, t_end, rng, [&](double t, double sigma_bar) {
    const Vec3 p = ray.origin + ray.direction * t;
    const MediumProperties mp = medium.at(p);
    // Emission by the collision estimator: E[Σ w·sigma_a·Le/σ̄ over collisions] = ∫ T sigma_a Le dt.
    f.emitted += f.weight * mp.sigma_a * mp.Le / sigma_bar;
    if (collide(f, mp, sigma_bar, rng.uniform())) return true;
    f.t = t;
    f.p = p;
    f.properties = mp;
    return false;
  });
  return f;
}

Rgb delta_tracking_transmittance(const Medium& medium, const scene::Ray& ray, double t_end, Pcg32& rng) {
  const FreeFlight f = sample_free_flight(medium, ray, t_end, rng);
  return f.event == FlightEvent::escaped ? f.weight : Rgb(0);
}

Rgb ratio_tracking_transmittance(const Medium& medium, const scene::Ray& ray, double t_end, Pcg32& rng) {
  Rgb T(1);
  track_majorants(medium, ray, t_end, rng, [&](double t, double sigma_bar) {
    const Rgb sigma_t = medium.at(ray.origin + ray.direction * t).sigma_t();
    T = T * null_coefficient(sigma_bar, sigma_t) / sigma_bar;
    if (T.max() == 0) return false;  // every channel is 0: nothing left to estimate
    if (T.max() >= kRouletteBelow) return true;
    if (rng.uniform() < kRouletteKill) return T = Rgb(0), false;
    T = T / (1 - kRouletteKill);
    return true;
  });
  return T;
}

}  // namespace kiln::volume
