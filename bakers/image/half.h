// IEEE 754 binary16 ("half") ↔ binary32 conversion, bit exact and independent of the FPU rounding mode.
#pragma once

#include <cstdint>

namespace kiln::image {

// float → half, rounding to nearest with ties to even (the IEEE default). Finite values of magnitude ≥ 65520 become
// ±infinity; values that fall below the normal range become half denormals (or ±0), rounded the same way; ±infinity
// stays ±infinity; a NaN stays a NaN with its sign and the top 10 bits of its payload (a payload that would become
// zero is replaced by the quiet bit, so the result is never mistaken for infinity).
uint16_t float_to_half(float value);

// half → float. Exact for every half value: denormals become normal floats, NaN payloads are kept bit for bit.
float half_to_float(uint16_t bits);

}  // namespace kiln::image
