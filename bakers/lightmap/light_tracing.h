// Indirect light by light tracing. Rays leave the lights (a light by power, then a point and a direction from its
// emission distribution, scene/light_emission.h), reflect off the surfaces as light does, and wherever a ray that has
// reflected at least once reaches the front of a traced texel, the flux it carries is deposited there. A texel's
// deposits over N rays, divided by N and by the world area the texel covers, estimate the mean indirect irradiance
// over the texel without bias: the texel is its own kernel. Every ray serves every texel it reaches, where a gathered
// path serves one, so the indirect light (smooth, and most of the work of a gathered path) costs a fraction of what
// gathering it does; the texels' own paths gather the direct light only (adaptive_sampler.h).
//
// Which texels are traced: those whose sample points stand on their surface (leak handling neither moved nor dropped
// any) and whose shading normals equal their geometric normal (within kFlatNormalCos): a deposit counts flux through
// the geometric surface, the irradiance about the shading normal would weigh it by cos θ_s / cos θ_g, which has no
// finite variance near grazing. The others gather all their light.
//
// A ray's first hit receives only direct light, which the texels gather themselves: the ray from the light and its
// emission sample buy only a point to reflect from. So each first hit reflects kFirstReflections times, each
// reflection carrying that share of the flux: the branches share their first hit, but deposit in different places,
// and on the Cornell box the error per deposit did not change from 1 to 16 branches while the rays per deposit fell
// from 2.3 to 1.3 (docs/PERFORMANCE.md).
//
// Reflection follows the transport's conventions (integrator.h): either side reflects, the shading normal shades, a
// direction below the geometric surface ends the ray. Light carries flux, so a reflection weighs by
// f(wo, wi) |ns·wi| |ng·wo| / (|ng·wi| pdf(wo)) with wi towards where the light came from and wo where it goes
// (Veach 1997, §5.3: the adjoint with shading normals); f is evaluated in that order, so non-reciprocal BSDFs are
// traced as they reflect. A ray continues with the probability of its throughput relative to where it started
// (Russian roulette, unbiased), so every deposit stays within a small factor of the ray's first flux.
//
// Random numbers: a PCG32 stream per block of rays (seeded by the bake's seed and the block's index, so the bytes do
// not depend on scheduling). Ray i belongs to replica i mod kReplicas; the rays are independent, so the replicas'
// spread is an honest standard error per texel (replica_sums.h). Quasi-random emission and first reflection (as
// gathered paths use, path_sampler.h) gave the same error on the Cornell box at 11 % more time: a texel's deposits
// come from wherever rays happen to land, which no stratification of the rays' start controls.
//
// Deposits are summed in fixed point (units of the lights' total power times 2^-24; a 64-bit sum holds 2^34 deposits
// of 2^5 times the first flux): integer sums do not depend on the order the threads add them in, so the bytes do
// not depend on the thread count.
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <new>
#include <vector>

#include "bakers/lightmap/integrator.h"
#include "bakers/lightmap/lightmap_state.h"
#include "bakers/lightmap/path_sampler.h"
#include "bakers/scene/alias_table.h"

namespace kiln::lightmap {

// A texel whose points' shading normals are all within this cosine of the geometric normal (0.001 rad) is flat:
// its deposits count as irradiance about the shading normal, an error below 5e-7 relative.
inline constexpr double kFlatNormalCos = 0.9999995;

// Reflections of each ray's first hit (see the header comment).
inline constexpr int kFirstReflections = 8;

// Marks the texels of `m` that light tracing serves (m.traced; see the header comment); returns how many.
size_t mark_traced_texels(LightmapState& m);

struct LightTracingCounts {
  uint64_t rays = 0;      // traced from the lights
  uint64_t deposits = 0;  // into traced texels
  bool out_of_time = false;
};

class LightTracer {
 public:
  // The lights that emit rays (LightSource::emits_rays) by power, but for delta lights the plan does not sample
  // (which no gathered path sees either); the traced texels of `maps` (mark_traced_texels) receive. `bounces`: the most
  // reflections a deposit's light has taken.
  LightTracer(const TransportContext& ctx, const std::vector<LightmapState>& maps, int bounces, uint64_t seed);
  // Some light emits rays.
  bool active() const { return !lights_.empty(); }

  // Traces the next `count` rays (rounded up to whole blocks). Stops at a block boundary once past `deadline` or
  // when `cancel` is set; the rays of the blocks not traced are not counted.
  LightTracingCounts trace(uint64_t count, std::chrono::steady_clock::time_point deadline,
                           const std::atomic<bool>* cancel);
  uint64_t rays_traced() const { return traced_; }

  // Texel t of lightmap `map`: the mean indirect irradiance over the rays so far, each replica's mean luminance,
  // and the deposits it has had.
  Rgb irradiance(size_t map, size_t texel) const;
  std::array<double, kReplicas> replica_luminance(size_t map, size_t texel) const;
  uint64_t deposits(size_t map, size_t texel) const { return maps_[map].texels[texel].deposits; }

  static constexpr uint64_t kBlock = 4096;  // rays per block: a multiple of kReplicas
  static const size_t kBytesPerTexel;        // the sums of every texel of a lightmap with traced texels

 private:
  // One texel's sums, together (a deposit touches two cache lines rather than one per array).
  struct alignas(64) TexelSums {
    double area = 0;  // world area the texel covers; 0: not traced
    int64_t deposits = 0;
    std::array<int64_t, 3> flux{};
    std::array<int64_t, kReplicas> flux_y{};
  };
  // Memory in 2 MiB pages where the kernel grants them (transparent huge pages): deposits land anywhere in a
  // lightmap's sums, and with 4 KiB pages most of them missed the TLB.
  template <class T>
  struct HugePages {
    using value_type = T;
    HugePages() = default;
    template <class U>
    HugePages(const HugePages<U>&) {}
    T* allocate(size_t n);
    void deallocate(T* p, size_t) { std::free(p); }
    template <class U>
    bool operator==(const HugePages<U>&) const {
      return true;
    }
  };
  struct Receiving {
    int width = 0, height = 0;
    std::vector<TexelSums, HugePages<TexelSums>> texels;
  };
  class PendingDeposits;
  struct Walker;

  const TransportContext& ctx_;
  int bounces_;
  uint64_t seed_;
  std::vector<int> lights_;  // indices into ctx.lights of those that emit rays
  scene::AliasTable choice_;
  std::vector<int> map_of_instance_;  // −1: the instance bakes no lightmap
  std::vector<Receiving> maps_;
  double unit_ = 1;          // flux per fixed-point step
  uint64_t traced_ = 0;      // rays of the blocks traced
  uint64_t next_block_ = 0;  // the first block not yet asked for
};

}  // namespace kiln::lightmap
