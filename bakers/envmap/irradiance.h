// A small irradiance cubemap by direct convolution of the environment with the clamped cosine (not from SH):
//     E(n) = ∫ L(ω) max(0, n·ω) dω  ≈  π · Σ_k L_k w_k / Σ_k w_k,   w_k = max(0, n·ω_k) ΔΩ_k,
// over every source texel k (centre direction ω_k, exact solid angle ΔΩ_k), n the centre of each output texel.
// The weights are rescaled so that they integrate the cosine exactly (∫ max(0, n·ω) dω = π): a constant environment
// L then gives π·L to rounding, and the rescaling changes any other result only by the rule's own O(1/N²) error on
// the cosine (N the source size). Cost: 36 · out_size² · N² multiply-adds; downsample the source (downsample_2x)
// first, the cosine lobe does not need more than N ≈ 32–64.
#pragma once

#include "bakers/envmap/cubemap.h"

namespace kiln::envmap {

// Runs in parallel over output texels with TBB. Throws std::invalid_argument for out_size < 1 or an empty source.
Cubemap irradiance_cubemap(const Cubemap& source, int out_size);

// The same convolution at one normal (need not be unit; the zero vector gives black): for tests and spot checks.
Rgb irradiance_at(const Cubemap& source, const Vec3& normal);

}  // namespace kiln::envmap
