#include "bakers/lightmap/irradiance_probes.h"

#include <algorithm>
#include <cmath>

#include <tbb/parallel_for.h>

#include "bakers/math/rng.h"

namespace kiln::lightmap {

void sample_probe(const TransportContext& ctx, const Vec3& p, size_t index, uint64_t seed, uint64_t from, uint64_t to,
                  ProbeSums& r) {
  // The deeper vertices' stream starts anew each round, seeded by where the round starts: deterministic rounds give
  // the same bytes.
  Pcg32 rng(seed + from * 0x9e3779b97f4a7c15ULL, index);
  for (uint64_t s = from; s < to; ++s) {
    const int replica = static_cast<int>(s % kReplicas);
    PathSampler sampler(seed * 0x9e3779b97f4a7c15ULL + index * kReplicas + replica,
                        static_cast<uint32_t>(s / kReplicas), rng);
    const ProbeEstimate e = estimate_probe(ctx, p, sampler);
    r.back_faces += e.back_face;
    r.rays += e.rays;
    r.dropped += e.dropped;
    ++r.taken;
    ++r.counts[replica];
    for (int k = 0; k < 9; ++k) r.sums[replica][k] += e.sh[k];
  }
}

ProbeSummary summarize_probe(const ProbeSums& r) {
  ProbeSummary out;
  double dc_sum = 0, dc_sum2 = 0;
  int replicas = 0;
  for (int q = 0; q < kReplicas; ++q) {
    for (int k = 0; k < 9; ++k) out.sh[k] += r.sums[q][k];
    if (r.counts[q] == 0) continue;  // fewer estimates than replicas: the spread of those that have one
    const double dc = luminance(r.sums[q][0]) / r.counts[q];
    dc_sum += dc;
    dc_sum2 += dc * dc;
    ++replicas;
  }
  const double n = static_cast<double>(std::max<uint64_t>(1, r.taken));
  for (Rgb& c : out.sh) c = c / n;
  out.dc_luminance = luminance(out.sh[0]);
  const double m = replicas ? dc_sum / replicas : 0.0;
  // One replica (or none) has no spread: the error is unknown, reported as infinite so the probe is sampled on.
  out.error = replicas > 1 ? std::sqrt(std::max(0.0, dc_sum2 / replicas - m * m) / (replicas - 1))
                           : std::numeric_limits<double>::infinity();
  out.valid = static_cast<double>(r.back_faces) <= kProbeBackFaceTolerance * static_cast<double>(r.taken);
  if (!out.valid) out.sh = ProbeSh{};
  return out;
}

std::vector<ProbeSummary> bake_probe_grid(const TransportContext& ctx, const ProbeGrid& grid, uint64_t samples,
                                          uint64_t seed) {
  std::vector<ProbeSummary> out(grid.count());
  tbb::parallel_for(size_t{0}, grid.count(), [&](size_t index) {
    const int i = static_cast<int>(index % grid.nx), j = static_cast<int>(index / grid.nx % grid.ny),
              k = static_cast<int>(index / (static_cast<size_t>(grid.nx) * grid.ny));
    ProbeSums sums;
    sample_probe(ctx, grid.position(i, j, k), index, seed, 0, samples, sums);
    out[index] = summarize_probe(sums);
  });
  return out;
}

}  // namespace kiln::lightmap
