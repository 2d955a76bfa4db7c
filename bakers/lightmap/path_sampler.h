// The random numbers of one lightmap path: randomised quasi-Monte Carlo where stratification pays, pseudo-random
// elsewhere.
//
// A texel's estimates fall into kReplicas interleaved replicas: estimate e belongs to replica e mod kReplicas, where
// it is point e / kReplicas of that replica's sequences. Each (sample point, replica) has its own Owen-scrambled
// Sobol sequences (owen_sobol.h), one per decision of the first kQmcVertices path vertices: the light chosen for
// next-event estimation, the point on it, the direction sampled (and the BSDF lobe). Those are where a texel's
// variance mostly comes from (soft shadows of area lights, the first bounce); deeper vertices draw from a PCG32
// stream, where stratification in high dimensions buys little (on the Cornell box, quasi-random decisions at all 9
// vertices gave the same error as at 2).
//
// Each sample point has sequences of its own rather than a share of one sequence over the texel: with consecutive
// indices per estimate, an index's lowest bits would pin each point to a few top-level strata for ever, and its
// replica's mean would converge to a scramble-dependent value (seen as texels 16 estimated errors off under two
// delta lights).
//
// Replicas are independent scrambles, so their means are independent estimates of the texel: the spread between them
// is an honest error estimate (replica_sums.h) where the ordinary variance of correlated, stratified estimates would
// overstate it.
#pragma once

#include <cstdint>

#include "bakers/math/owen_sobol.h"
#include "bakers/math/rng.h"
#include "bakers/math/sampling.h"

namespace kiln::lightmap {

inline constexpr int kReplicas = 8;

class PathSampler {
 public:
  // The vertices whose decisions are quasi-random: the receiver (0) and the first surface the path reaches (1).
  static constexpr int kQmcVertices = 2;

  // `sequence_seed`: of this (texel sample point, replica); `index`: the estimate's point in it; `rng`: the stream
  // for the deeper vertices.
  PathSampler(uint64_t sequence_seed, uint32_t index, Pcg32& rng)
      : seed_(static_cast<uint32_t>(sequence_seed ^ (sequence_seed >> 32))), index_(index), rng_(rng) {}

  double light_choice(int vertex) { return one(vertex, Dimension::light_choice); }
  Point2 light_point(int vertex) { return two(vertex, Dimension::light_point); }
  Point2 direction(int vertex) { return two(vertex, Dimension::direction); }
  double lobe(int vertex) { return one(vertex, Dimension::lobe); }
  double roulette() { return rng_.uniform32(); }
  // The pseudo-random stream itself, for the tracking estimators through media (volume/tracking.h).
  Pcg32& rng() { return rng_; }
  // A cosine-weighted direction around +z (pdf cos θ/π): through the stratified map at the quasi-random vertices,
  // by rejection (no trigonometry) deeper.
  Vec3 cosine_direction(int vertex) {
    return vertex < kQmcVertices ? sample_cosine_hemisphere(direction(vertex)) : sample_cosine_hemisphere(rng_);
  }

 private:
  enum class Dimension : uint32_t { light_choice, light_point, direction, lobe };

  uint32_t seed(int vertex, Dimension d) const {
    const uint32_t dimension = static_cast<uint32_t>(vertex) * 4 + static_cast<uint32_t>(d) + 1;
    return owen_sobol_detail::hash32(seed_ + 0x9e3779b9u * dimension);
  }
  double one(int vertex, Dimension d) {
    return vertex < kQmcVertices ? owen_sobol_1d(index_, seed(vertex, d)) : rng_.uniform32();
  }
  Point2 two(int vertex, Dimension d) {
    if (vertex < kQmcVertices) return owen_sobol_2d(index_, seed(vertex, d));
    return {rng_.uniform32(), rng_.uniform32()};
  }

  uint32_t seed_;
  uint32_t index_;
  Pcg32& rng_;
};

}  // namespace kiln::lightmap
