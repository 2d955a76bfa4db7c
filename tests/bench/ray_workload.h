// Incoherent ray workloads for throughput measurements: the "raw Embree" baseline of tracer_bench, and the same
// kind of rays the lightmap benchmark compares its own throughput against.
#pragma once

#include <cstdint>
#include <vector>

#include "bakers/math/rng.h"
#include "bakers/math/sampling.h"
#include "bakers/scene/ray_offset.h"

namespace kiln::bench {

// `count` rays with origins uniform in the box [lower, upper] shrunk by 10% on each side (inside a room: every ray
// hits something) and directions uniform on the sphere: as incoherent as path-traced bounces get. tmax: infinite for
// closest-hit rays; for occlusion rays (shadow rays towards a light) uniform in (0, |upper − lower|).
inline std::vector<scene::Ray> incoherent_rays(const Vec3& lower, const Vec3& upper, size_t count, bool occlusion,
                                               uint64_t seed = 1) {
  Pcg32 rng(seed);
  const Vec3 extent = upper - lower;
  const Vec3 lo = lower + extent * 0.1;
  const double diagonal = length(extent);
  std::vector<scene::Ray> rays(count);
  for (scene::Ray& r : rays) {
    r.origin =
        lo + Vec3{extent.x * 0.8 * rng.uniform(), extent.y * 0.8 * rng.uniform(), extent.z * 0.8 * rng.uniform()};
    r.direction = sample_uniform_sphere({rng.uniform(), rng.uniform()});
    r.tmax = occlusion ? diagonal * (1 - rng.uniform()) : INFINITY;
  }
  return rays;
}

}  // namespace kiln::bench
