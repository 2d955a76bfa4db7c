// The rays a lightmap bake traces, recorded as it traces them: for benchmarks that replay the baker's own rays through
// the tracer alone (its "raw Embree" baseline is then rays of exactly the baker's kind: origins on the surfaces,
// cosine- and BSDF-distributed directions, shadow rays ending on the lights, and the leak probes). Not
// part of a job: the service never sets one, and a bake without it pays one predictable branch per ray.
//
// Thread safety: any number of threads may record at once; each ray takes the next slot (one atomic increment), and
// rays past the capacity are counted but not kept. Read the rays only after the bake has returned.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "bakers/scene/ray_offset.h"

namespace kiln::lightmap {

// What a ray was traced for. The baker spends very different work around each kind (a leak probe needs none
// beyond its query), so a replay keeps their mix, each kind from its own recording.
enum class RayKind : uint8_t {
  closest,    // the transport's closest-hit queries: cosine- and BSDF-sampled directions
  occlusion,  // the transport's shadow (any-hit) queries
  probe,      // leak probes (leaks.h): closest-hit queries over the hemisphere of every sample point, before the passes
};

class RayLog {
 public:
  explicit RayLog(size_t capacity) : rays_(capacity), kinds_(capacity) {}

  void record(const scene::Ray& ray, RayKind kind) {
    const size_t i = next_.fetch_add(1, std::memory_order_relaxed);
    if (i >= rays_.size()) return;
    rays_[i] = ray;
    kinds_[i] = kind;
  }

  // The rays kept, in the order their slots were taken, and what each was traced for.
  size_t size() const { return std::min(next_.load(), rays_.size()); }
  const scene::Ray& ray(size_t i) const { return rays_[i]; }
  RayKind kind(size_t i) const { return kinds_[i]; }
  // Every ray offered, kept or not.
  uint64_t offered() const { return next_.load(); }

 private:
  std::vector<scene::Ray> rays_;
  std::vector<RayKind> kinds_;
  std::atomic<size_t> next_{0};
};

}  // namespace kiln::lightmap
