#pragma once

namespace kiln {
inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kInvPi = 1.0 / kPi;
inline constexpr double kInv2Pi = 1.0 / (2.0 * kPi);
inline constexpr double kInv4Pi = 1.0 / (4.0 * kPi);
inline constexpr double kPiOver2 = kPi / 2.0;
inline constexpr double kPiOver4 = kPi / 4.0;
// The largest double below 1: what keeps a uniform or a sampled coordinate in [0, 1).
inline constexpr double kOneMinusEpsilon = 0x1.fffffffffffffp-1;
}  // namespace kiln
