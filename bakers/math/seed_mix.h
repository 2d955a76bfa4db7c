// Seeds derived from seeds: one random stream per (bake seed, lightmap, texel, block …), whatever thread computes it,
// so that a bake's bytes do not depend on scheduling.
#pragma once

#include <cstdint>

namespace kiln {

// A well-mixed 64-bit seed from two: a boost::hash_combine-style combination followed by two rounds of
// SplitMix64's finaliser, so that nearby inputs (texel t and t + 1) give unrelated seeds.
inline uint64_t mix_seeds(uint64_t a, uint64_t b) {
  uint64_t x = a * 0x9E3779B97F4A7C15ull ^ (b + 0x632BE59BD9B4E019ull + (a << 6) + (a >> 2));
  x ^= x >> 31;
  x *= 0xBF58476D1CE4E5B9ull;
  x ^= x >> 27;
  return x;
}

}  // namespace kiln
