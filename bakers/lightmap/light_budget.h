// How many rays light tracing traces (light_tracing.h), and which traced texels it leaves to gathering.
//
// A traced texel's error has two independent parts, its own estimates of the direct light and the traced term:
// e² = v/n + c/N, with n its estimates, N the rays from the lights, v and c the variances of one of each under the
// error metric. The bake asks e ≤ τ (the target) of every texel, so a texel needs n = v / (τ² − c/N) estimates. A
// texel whose traced term would take more than kTracedMaxShare of τ² (little area, or little light reaching it)
// gathers all its light instead, as does one whose traced neighbourhood (the 3×3 texels its variances are pooled
// over) has fewer than kMinDeposits deposits, whose replicas' spread is not yet a reliable error. Gathering all of
// its light, a texel needs about n = (v + κ·y²) / τ² estimates of the full path, y its indirect light under the
// metric and κ = kIndirectVariance.
//
// The rays serve every texel at once, so N is chosen for the whole bake: the N that minimises the time
//   a·N + b·Σ_traced v / (τ² − c/N) + b_full·Σ_gathering (v + κ·y²) / τ²,
// with a the cost of a ray from the lights (with its reflections), b and b_full of a direct and of a full estimate,
// all counted in rays traced (kLightRayCost weighs light tracing's), so that the bytes do not depend on the machine.
// For one kind of texel the traced part gives c/N = τ² / (1 + √(T b v / (a c))): the rays take the larger share of τ²
// the cheaper they are; texels that light tracing serves badly (small ones, dark ones) cost more rays than they save
// and gather, as they would without it.
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
// The relative variance of a gathered estimate's indirect light, as the budget counts it. A path's is about 1 (0.87
// on the Cornell box's ceiling, which has no direct light) and an estimate averages P paths, but counting it as 1 per
// estimate made the bakes faster (docs/PERFORMANCE.md): a texel handed back costs more than its variance says (its
// rare-event floor, its neighbours' pooling). It sets only the share of rays, not what an estimate converges to.
inline constexpr double kIndirectVariance = 1.0;

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
  double y = 0;         // its traced term's mean luminance under the metric
  double min_rays = 0;  // for kMinDeposits deposits in its neighbourhood at their rate so far; +∞ with none
};

// A ray that light tracing traces costs about this many of a gathered path's (Cornell box: 0.53-0.60 µs against
// 0.50, 0.35-0.45 against 0.30; deposits and reflections against shading and shadow rays).
inline constexpr double kLightRayCost = 1.2;

// Rays traced per estimate of a traced texel (its direct light) and of a texel gathering all its light.
struct GatherCosts {
  double direct = 0, full = 0;
};

std::vector<TracedTexel> traced_texels(const std::vector<LightmapState>& maps, const LightTracer& tracer,
                                       ErrorMetric metric);

// True when texel `x` at N rays cannot keep its traced term (see the header comment).
bool gathers_instead(const TracedTexel& x, double rays, double target_error);

// The N above, searched from `rays_now` up to 4096 times that; `cost_per_ray` and `costs` in rays traced.
double best_light_rays(const std::vector<TracedTexel>& texels, double target_error, double rays_now,
                       double cost_per_ray, const GatherCosts& costs);

}  // namespace kiln::lightmap
