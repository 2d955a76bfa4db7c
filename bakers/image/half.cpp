#include "bakers/image/half.h"

#include <bit>

namespace kiln::image {

uint16_t float_to_half(float value) {
  const uint32_t x = std::bit_cast<uint32_t>(value);
  const uint32_t sign = (x >> 16) & 0x8000u;
  const uint32_t ax = x & 0x7fffffffu;

  if (ax >= 0x7f800000u) {  // infinity or NaN
    if (ax == 0x7f800000u) return static_cast<uint16_t>(sign | 0x7c00u);
    uint32_t payload = (ax >> 13) & 0x3ffu;
    if (payload == 0) payload = 0x200u;  // keep it a NaN
    return static_cast<uint16_t>(sign | 0x7c00u | payload);
  }
  // 65520 = 65504 + half an ulp (32/2): from there on, round-to-nearest-even gives infinity.
  if (ax >= 0x477ff000u) return static_cast<uint16_t>(sign | 0x7c00u);

  if (ax >= 0x38800000u) {  // ≥ 2^-14: a normal half. Rebias the exponent (127 → 15) and drop 13 mantissa bits.
    uint32_t r = ax - 0x38000000u;
    r += 0x0fffu + ((r >> 13) & 1u);  // round to nearest, ties to even; a carry correctly bumps the exponent
    return static_cast<uint16_t>(sign | (r >> 13));
  }
  // Below 2^-14: a half denormal m·2^-24 (m = 1024 rounds up to the smallest normal, which has the same encoding).
  // Magnitudes ≤ 2^-25 (half of the smallest denormal; a tie goes to the even 0) become ±0.
  if (ax <= 0x33000000u) return static_cast<uint16_t>(sign);
  const uint32_t exponent = ax >> 23;                      // 102 … 112 here
  const uint32_t mantissa = (ax & 0x7fffffu) | 0x800000u;  // with the implicit bit
  const uint32_t shift = 126u - exponent;                  // value·2^24 = mantissa·2^(exponent−126)
  uint32_t m = mantissa >> shift;
  const uint32_t rest = mantissa & ((1u << shift) - 1u);
  const uint32_t halfway = 1u << (shift - 1u);
  if (rest > halfway || (rest == halfway && (m & 1u))) ++m;
  return static_cast<uint16_t>(sign | m);
}

float half_to_float(uint16_t bits) {
  const uint32_t sign = (static_cast<uint32_t>(bits) & 0x8000u) << 16;
  const uint32_t exponent = (bits >> 10) & 0x1fu;
  uint32_t mantissa = bits & 0x3ffu;
  if (exponent == 0x1fu) return std::bit_cast<float>(sign | 0x7f800000u | (mantissa << 13));
  if (exponent != 0) return std::bit_cast<float>(sign | ((exponent + 112u) << 23) | (mantissa << 13));
  if (mantissa == 0) return std::bit_cast<float>(sign);
  // Denormal m·2^-24: normalise so the leading 1 sits at bit 10.
  uint32_t e = 113u;  // float biased exponent of 2^-14
  while ((mantissa & 0x400u) == 0) {
    mantissa <<= 1;
    --e;
  }
  return std::bit_cast<float>(sign | (e << 23) | ((mantissa & 0x3ffu) << 13));
}

}  // namespace kiln::image
