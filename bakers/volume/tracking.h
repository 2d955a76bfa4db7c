// Tracking estimators against a medium's majorants (docs/MEDIA.md derives each): tentative collisions are a Poisson
// process of rate sigma_maj along the ray; at each, the medium's real coefficients decide what happens. Every
// estimator here is unbiased for every RGB channel at once, and deterministic given the generator's state.
//
// Spectral coefficients share one grey majorant per segment, the largest channel's: σ̄ = max_c sigma_maj[c] ≥
// sigma_t[c] for every c, so the null coefficient sigma_n[c] = σ̄ − sigma_t[c] is never negative in any channel. With
// one σ̄ for all channels the distance sampling is the same for each, and pbrt-v4's per-channel ratios r_u, r_l of
// SampleT_maj are all 1: what differs between channels is carried by the weights of the collision events (spectral
// tracking, Kutz et al. 2017), or by the ratio-tracking product.
#pragma once

#include <cmath>

#include "bakers/math/rgb.h"
#include "bakers/math/rng.h"
#include "bakers/scene/ray_offset.h"
#include "bakers/volume/medium.h"

namespace kiln::volume {

// Samples the tentative collisions of ray over [0, t_end) against the medium's majorants, calling
// at_collision(t, sigma_bar) at each (sigma_bar: the segment's grey majorant per unit length) until it returns false.
// Returns true if the ray left [0, t_end) without being stopped (always, for a ray that does not move or has a
// non-finite coordinate). Segments with a zero majorant are passed over
// whole without a random number (empty space). Each step draws one uniform from rng.
template <class AtCollision>
bool track_majorants(const Medium& medium, const scene::Ray& ray, double t_end, Pcg32& rng,
                     AtCollision&& at_collision) {
  // Coefficients are per unit of length and t is in units of |direction|: a step in t is a distance / speed.
  const double speed = length(ray.direction);
  // A ray that does not move crosses no medium. A ray with a NaN or infinite coordinate (a caller's bug) has no
  // place to look the medium up: it crosses none either, rather than feeding NaN to the lookups.
  if (!(speed > 0) || !std::isfinite(speed) || !is_finite(ray.origin)) return true;
  MajorantIterator segments = medium.majorants(ray, t_end);
  while (const auto segment = segments.next()) {
    const double sigma_bar = segment->sigma_maj.max();
    if (sigma_bar == 0) continue;  // empty space: nothing to collide with
    // Exponential steps of mean 1/(σ̄·speed); uniform() < 1 keeps log1p(−u) finite. Past the segment's end the
    // walk restarts at the next segment's start (the exponential distribution is memoryless).
    for (double t = segment->t_min;;) {
      t -= std::log1p(-rng.uniform()) / (sigma_bar * speed);
      if (t >= segment->t_max) break;
      if (!at_collision(t, sigma_bar)) return false;
    }
  }
  return true;
}

enum class FlightEvent { escaped, absorbed, scattered };

// What a free flight ended in, and the weights of its spectral-tracking estimator.
struct FreeFlight {
  FlightEvent event = FlightEvent::escaped;
  double t = 0;                 // the collision's t (t_end if escaped)
  Vec3 p;                       // the collision point (scattered)
  MediumProperties properties;  // the medium at p (scattered)
  Rgb weight{1, 1, 1};          // multiplies the path throughput on escape or scattering; 0 when absorbed
  Rgb emitted;                  // the medium's emission collected on the way, already weighted (add it × throughput)
};

// Delta tracking (Woodcock et al. 1965) in its spectral, history-aware form (Kutz et al. 2017, §5.2): at a tentative
// collision, absorption, scattering or a null collision is chosen with probabilities proportional to
// max_c(w·sigma_a), max_c(w·sigma_s), max_c(w·sigma_n), and the weight w is multiplied by sigma_x / (σ̄·P_x).
FreeFlight sample_free_flight(const Medium& medium, const scene::Ray& ray, double t_end, Pcg32& rng);

// Transmittance over [0, t_end) by delta tracking: the weight of a free flight that escapes, else 0.
Rgb delta_tracking_transmittance(const Medium& medium, const scene::Ray& ray, double t_end, Pcg32& rng);

// Transmittance over [0, t_end) by ratio tracking (Novák et al. 2014): the product of sigma_n/σ̄ over the tentative
// collisions, with Russian roulette once every channel is small.
Rgb ratio_tracking_transmittance(const Medium& medium, const scene::Ray& ray, double t_end, Pcg32& rng);

}  // namespace kiln::volume
