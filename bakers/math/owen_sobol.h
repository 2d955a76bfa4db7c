// Owen-scrambled Sobol points in one and two dimensions, by hashing (Laine & Karras 2011; Burley, "Practical
// Hash-based Owen Scrambling", JCGT 2020).
//
// Sobol's first two dimensions form a (0, 2)-sequence in base 2: every aligned run of 2^m points (indices
// [k·2^m, (k+1)·2^m)) puts exactly one point in each of the 2^m elementary intervals of every shape (1 × 2^m,
// 2 × 2^(m−1), …), so a pass over a pixel with a power-of-two count stratifies its light point and its direction
// both jointly and in each coordinate. Owen's nested uniform scrambling keeps that net property while making each
// point uniformly distributed: every estimate stays unbiased, and independently scrambled copies are independent, so
// the spread between copies measures the error honestly (randomised QMC).
//
// Nested scrambling flips bit k of a coordinate (k = 0 the most significant) by a random function of the bits above
// it. With the bits reversed, "above" becomes "below", and any map in which each output bit is the input bit XOR a
// function of lower bits qualifies: additions, multiplications by odd numbers, x ^= x·even. The index itself is
// scrambled the same way (Burley's shuffle): the points come in a random order, and an aligned run of 2^m indices
// still maps to an aligned run of 2^m points, which is the net.
//
// Different dimensions of a path (the light's point, the direction) use independent seeds: each pair is a net on
// its own, and the pairs are decorrelated by their scrambles ("padding" in Burley's paper).
#pragma once

#include <cstdint>

#include "bakers/math/sampling.h"

namespace kiln {

namespace owen_sobol_detail {

inline uint32_t reverse_bits(uint32_t x) {
  x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
  x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
  x = ((x >> 4) & 0x0F0F0F0Fu) | ((x & 0x0F0F0F0Fu) << 4);
  x = ((x >> 8) & 0x00FF00FFu) | ((x & 0x00FF00FFu) << 8);
  return (x >> 16) | (x << 16);
}

// A 32-bit finaliser (a bijection with full avalanche), to turn structured seeds into unrelated ones.
inline uint32_t hash32(uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352du;
  x ^= x >> 15;
  x *= 0x846ca68bu;
  x ^= x >> 16;
  return x;
}

// A seeded bijection of 32-bit words in which output bit k is input bit k XOR a function of bits 0..k−1 and the
// seed: on bit-reversed values, one draw of a nested uniform (Owen) scramble. The steps: adds (carries rise),
// multiplications by even constants XORed in, and a multiplication by a seed-dependent odd number. `seed` must be
// well mixed (a hash32 output): its bits are used directly.
inline uint32_t permute_reversed(uint32_t x, uint32_t seed) {
  x += seed;
  x ^= x * 0x2c1b3c6cu;
  x *= (seed >> 12) | 1u;
  x ^= x * 0x8e5d4b7au;
  x += (seed * 0x9e3779b9u) ^ (seed >> 16);
  x ^= x * 0x61c88646u;
  return x;
}

// Owen scramble of a value whose bit 31 is its most significant binary digit.
inline uint32_t nested_scramble(uint32_t v, uint32_t seed) {
  return reverse_bits(permute_reversed(reverse_bits(v), seed));
}

// Sobol's second dimension: generator matrix with direction numbers v_k = v_{k−1} XOR (v_{k−1} >> 1), v_0 = 2^31.
// (The first is the van der Corput sequence, reverse_bits(index).) The product with an index is the XOR of the
// direction numbers of its set bits; the shuffled indices use all 32 bits, so it is tabulated a byte at a time: entry
// [b][v] is the XOR of the direction numbers of the bits set in v, placed at bits 8b..8b+7 of the index.
struct SobolDimension1Table {
  uint32_t entry[4][256];
  constexpr SobolDimension1Table() : entry{} {
    uint32_t v[32] = {};
    v[0] = 1u << 31;
    for (int k = 1; k < 32; ++k) v[k] = v[k - 1] ^ (v[k - 1] >> 1);
    for (int b = 0; b < 4; ++b) {
      for (int value = 0; value < 256; ++value) {
        uint32_t x = 0;
        for (int bit = 0; bit < 8; ++bit) {
          if (value & (1 << bit)) x ^= v[8 * b + bit];
        }
        entry[b][value] = x;
      }
    }
  }
};
inline constexpr SobolDimension1Table kSobolDimension1{};

inline uint32_t sobol_dimension1(uint32_t index) {
  const auto& t = kSobolDimension1.entry;
  return t[0][index & 0xFFu] ^ t[1][(index >> 8) & 0xFFu] ^ t[2][(index >> 16) & 0xFFu] ^ t[3][index >> 24];
}

inline double to_unit(uint32_t v) { return v * 0x1.0p-32; }  // [0, 1), never 1

}  // namespace owen_sobol_detail

// Point `index` of the scrambled sequence `seed`: uniform on [0, 1)², an aligned run of 2^m indices a (0, m, 2)-net.
inline Point2 owen_sobol_2d(uint32_t index, uint32_t seed) {
  using namespace owen_sobol_detail;
  const uint32_t i = nested_scramble(index, hash32(seed ^ 0x5bd1e995u));
  // nested_scramble(reverse_bits(i), s) with the two reversals of i cancelled.
  const uint32_t x = reverse_bits(permute_reversed(i, hash32(seed ^ 0x27d4eb2fu)));
  const uint32_t y = nested_scramble(sobol_dimension1(i), hash32(seed ^ 0x165667b1u));
  return {to_unit(x), to_unit(y)};
}

// The one-dimensional case: a scrambled van der Corput sequence (an aligned run of 2^m indices puts one point in
// each interval [j/2^m, (j+1)/2^m)).
inline double owen_sobol_1d(uint32_t index, uint32_t seed) {
  using namespace owen_sobol_detail;
  const uint32_t i = nested_scramble(index, hash32(seed ^ 0x5bd1e995u));
  return to_unit(reverse_bits(permute_reversed(i, hash32(seed ^ 0x9e3779b9u))));
}

}  // namespace kiln
