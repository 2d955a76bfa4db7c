// PCG32 (O'Neill 2014): a small, fast generator with independent streams, so every sample set is reproducible.
#pragma once

#include <cstdint>

namespace kiln {

class Pcg32 {
 public:
  explicit Pcg32(uint64_t seed = 0x853c49e6748fea9bULL, uint64_t stream = 0xda3e39cb94b95bdbULL) {
    inc_ = (stream << 1u) | 1u;
    state_ = 0;
    next_u32();
    state_ += seed;
    next_u32();
  }

  uint32_t next_u32() {
    const uint64_t old = state_;
    state_ = old * 6364136223846793005ULL + inc_;
    const uint32_t xorshifted = static_cast<uint32_t>(((old >> 18u) ^ old) >> 27u);
    const uint32_t rot = static_cast<uint32_t>(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((~rot + 1u) & 31u));
  }

  // Uniform in [0, 1): 53 random bits, never 1.0.
  double uniform() {
    const uint64_t hi = next_u32(), lo = next_u32();
    return static_cast<double>(((hi << 32) | lo) >> 11) * 0x1.0p-53;
  }
  // Uniform in [0, 1) on a grid of 2^-32 (one step of the generator instead of two), never 1.0: for choices and
  // points that need no finer resolution than a float's (a light, a point on it, a Russian-roulette draw).
  double uniform32() { return static_cast<double>(next_u32()) * 0x1.0p-32; }

 private:
  uint64_t state_, inc_;
};

}  // namespace kiln
