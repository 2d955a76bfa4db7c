// The adaptive passes of the lightmap bake. Every estimate of a texel is one path per sample point of the texel,
// weighted by the point's share of it. Each pass gives every texel still short of its goal a batch of estimates: up
// to min_samples first, then as many as its (pooled) variance says the target needs, up to max_samples. Batches grow
// with what a texel already has (at most half as many again per pass, at least one), so a bake takes tens of passes
// rather than thousands (scheduling and the error summary run between passes, on all texels) and the error curve
// still has a point per pass.
//
// Each estimate draws its first path vertices from the quasi-random sequences of (bake seed, lightmap, texel, sample
// point, replica) at its index in the replica (path_sampler.h), and its deeper ones from a stream seeded by (bake
// seed, lightmap, texel, index of the estimate's batch piece), so the bytes depend neither on the thread count nor
// on the order of execution. Batches are whole rounds of the replicas.
#pragma once

#include <chrono>
#include <cstdint>
#include <vector>

#include "bakers/bake/control.h"
#include "bakers/lightmap/error_metric.h"
#include "bakers/lightmap/integrator.h"
#include "bakers/lightmap/lightmap_state.h"

namespace kiln::lightmap {

struct SamplingOptions {
  double target_error = 0.01;  // per texel under `metric`, (0, 1]
  ErrorMetric metric = ErrorMetric::lightmap;
  uint64_t min_samples = 16;    // per texel before any texel may stop
  uint64_t max_samples = 4096;  // per texel, counting dropped estimates
  uint64_t seed = 1;
  bool directional = false;  // accumulate the SH sums too
  // Past it, a pass stops where it is: the texels not reached keep what they have.
  std::chrono::steady_clock::time_point deadline = std::chrono::steady_clock::time_point::max();
};

// A texel's batch of estimates in one pass.
struct TexelBatch {
  uint32_t map;    // into the lightmaps
  uint32_t batch;  // estimates
  size_t texel;
};

// What one pass traced and dropped.
struct PassCounts {
  uint64_t rays = 0, occlusion_rays = 0, paths = 0, general_vertices = 0;
  uint64_t dropped = 0;      // estimates with a non-finite contribution, or not acceptable as irradiance
  bool out_of_time = false;  // the pass stopped at the deadline
  // Of the estimates and rays above, those of texels light tracing serves (direct light only).
  uint64_t estimates = 0, traced_estimates = 0, traced_rays = 0;
};

// The texels still short of their goal, with their batches, lightmap by lightmap in row-major order. Empty when
// every texel is done.
std::vector<TexelBatch> schedule_pass(const std::vector<LightmapState>& maps, const SamplingOptions& options);

// Runs the batches and merges their estimates into the lightmaps. Returns early (without throwing) once
// control.cancel is set; the caller checks it.
// `direct_ctx`, when given, estimates the traced texels (LightmapState::traced): its plan has no bounces, since
// light tracing brings their indirect light.
PassCounts run_pass(std::vector<LightmapState>& maps, const std::vector<TexelBatch>& batches,
                    const TransportContext& ctx, const SamplingOptions& options, const bake::BakeControl& control,
                    const TransportContext* direct_ctx = nullptr);

}  // namespace kiln::lightmap
