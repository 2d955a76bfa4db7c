// How many rays light tracing traces (light_tracing.h), and which traced texels it leaves to gathering.
//
// A traced texel's error has two independent parts, its own estimates of the direct light and the traced term:
// e² = v/n + c/N, with n its estimates, N the rays from the lights, v and c the variances of one of each under the
// error metric. The bake asks e ≤ τ (the target) of every texel, so a texel needs n = v / (τ² − c/N) estimates. The
// rays serve every texel at once, so N is chosen for the whole bake: the N that minimises the time
//   a·N + b·Σ_t v_t / (τ² − c_t/N),
// with a the seconds per ray from the lights and b per estimate, both measured. For one kind of texel this gives
// c/N = τ² / (1 + √(T b v / (a c))): the rays take the larger share of τ² the cheaper they are. A texel whose traced
// term would take more than kTracedMaxShare of τ² (little area, or little light reaching it) gathers all its light
// instead, as does one whose traced neighbourhood (the 3×3 texels its variances are pooled over) has fewer than
// kMinDeposits deposits, whose replicas' spread is not yet a reliable error.
// Gathering all of a texel's light costs many times its direct light (the indirect light is most of a path's work
// and variance), so N is at least what keeps the texels covering all but kMostGathered of the traced area traced.
// By area, because rays serve a texel in proportion to its area while gathering costs the same for any texel: the
// texels that light tracing serves worst are the smallest (a small object's map at the resolution of a large one's),
// and those gather as they would without it.
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

#include "bakers/lightmap/error_metric.h"
#include "bakers/lightmap/light_tracing.h"
#include "bakers/lightmap/lightmap_state.h"

namespace kiln::lightmap {

inline constexpr double kTracedMaxShare = 0.9;
inline constexpr double kMinDeposits = 8 * kReplicas;
inline constexpr double kMostGathered = 0.01;

// The variance a traced texel's own estimates may leave, given its traced term's `traced_variance` under the metric:
// target² less that, at least (1 − kTracedMaxShare)·target². The adaptive sampler aims at it, and the budget above
// counts the estimates it costs.
inline double gathered_allowance(double target2, double traced_variance) {
  return std::max(target2 - traced_variance, (1 - kTracedMaxShare) * target2);
}

// One traced texel's variances (pooled over its traced 3×3 neighbours, as the adaptive sampler pools) and the rays
// its deposits ask for.
struct TracedTexel {
  size_t map = 0, texel = 0;
  double v = 0;         // of one of its own estimates, under the metric (0: none yet)
  double c = 0;         // of the traced term times the rays so far, under the metric
  double min_rays = 0;  // for kMinDeposits deposits in its neighbourhood at their rate so far; +∞ with none
  double area = 0;      // world area the texel covers
};

std::vector<TracedTexel> traced_texels(const std::vector<LightmapState>& maps, const LightTracer& tracer,
                                       ErrorMetric metric);

// True when texel `x` at N rays cannot keep its traced term (see the header comment).
bool gathers_instead(const TracedTexel& x, double rays, double target_error);

// The N above, searched from the least that keeps 1 − kMostGathered of the traced area traced (and `rays_now`) up to 64
// times that; `seconds_per_ray` and `seconds_per_estimate` measured. +∞ while most texels have had no deposit.
double best_light_rays(const std::vector<TracedTexel>& texels, double target_error, double rays_now,
                       double seconds_per_ray, double seconds_per_estimate);

}  // namespace kiln::lightmap
