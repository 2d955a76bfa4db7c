// The specular prefiltered mip chain of an environment under the split-sum assumption n = v = r (Karis 2013,
// "Real Shading in Unreal Engine 4"): level k holds the environment convolved with the GGX lobe weighted by n·l,
//
//     L_pre(n) = ∫ L(l) D(h) (n·l) dω_l / ∫ D(h) (n·l) dω_l,      h = (n + l)/|n + l|,
//
// with the normalisation by the integral of the weights (so a constant environment stays exactly that constant).
// Why D(h)(n·l): importance sampling h from D(h)(n·h) (GGX visible normals seen from v = n, Heitz 2018) and
// reflecting v about h gives l with density p(l) = D(h)(n·h)/(4 v·h) = D(h)/4, so Karis's estimator
// Σ L(l_i)(n·l_i) / Σ (n·l_i) converges to the ratio above.
//
// ## Roughness of each level (the one mapping)
// Level k of L levels has perceptual roughness ρ_k = k/(L − 1) (level 0 = mirror, the last level ρ = 1), and the
// GGX width is α = ρ² (bakers/envmap/dfg.h). Level k has size max(1, out_size >> k) (a mip chain).
//
// ## Filtered importance sampling (Křivánek & Colbert 2008, GPU Gems 3 ch. 20)
// Each sample reads the source's own mip chain (built with downsample_2x) at
//     lod = ½ log2(Ω_s/Ω_p) + 1,   Ω_s = 1/(N p(l)),   Ω_p = 4π/(6 size0²),
// clamped to [0, last source level], trilinear (bilinear on each face with seamless edges, linear between levels).
//
// ## Error estimate
// The N samples are 4 groups of N/4: each group is the same N/4-point Hammersley set with its own Cranley–Patterson
// rotation (a fixed pseudo-random shift per group, the same for every texel, so the output has no per-texel noise).
// The 4 group estimates are independent unbiased-in-distribution estimates (randomised QMC); the standard error of the
// combined estimate at a texel is s/√4 with s the sample standard deviation of the group means (of the average
// channel). error_estimate is the relative RMS over all texels of (standard error / |value|), guarded against
// zero values. It measures integration noise only, not the (small, deliberate) blur of filtered importance sampling.
#pragma once

#include <vector>

#include "bakers/envmap/cubemap.h"

namespace kiln::envmap {

struct PrefilterOptions {
  int levels = 6;    // L ≥ 1; level k has ρ = k/(L − 1)
  int samples = 64;  // N per texel for levels k ≥ 1; rounded up to a multiple of 4 (the error groups)
};

struct PrefilteredLevel {
  double roughness = 0;       // perceptual ρ; α = ρ²
  Cubemap cube;               // size max(1, out_size >> k)
  double error_estimate = 0;  // relative RMS standard error over texels (see above); 0 for level 0 (no sampling)
};

// Perceptual roughness of level k of `levels` (ρ_k = k/(L − 1); a single level is the mirror, ρ = 0).
double prefilter_level_roughness(int level, int levels);

// The whole chain, in parallel (TBB) over output texels. Level 0 is the source at out_size: the source itself if
// out_size equals the size of one of its mip levels, else bilinearly resampled. Throws std::invalid_argument for
// out_size < 1, levels < 1, samples < 1 or an empty source.
std::vector<PrefilteredLevel> prefilter_specular(const Cubemap& source, int out_size,
                                                 const PrefilterOptions& options = {});

// One level at roughness rho ∈ (0, 1] by (filtered) importance sampling; `error_estimate` receives the relative RMS
// standard error if not null. The source mip chain is passed in (mips[0] = source).
Cubemap prefilter_level(const std::vector<Cubemap>& source_mips, int out_size, double rho, int samples,
                        double* error_estimate = nullptr);

// The source mip chain used by filtered importance sampling: source, then downsample_2x while the size is even.
std::vector<Cubemap> build_source_mips(const Cubemap& source);

// Reference: the same normalised lobe summed over every source texel with exact solid angles,
//     L_ref(n) = Σ_texels L_j D(h_j)(n·l_j) Ω_j / Σ_texels D(h_j)(n·l_j) Ω_j.
// With subdivisions k > 1 every texel is split into k × k sub-texels, each with its own exact solid angle
// (face_rect_solid_angle) and its radiance read with sample_bilinear (the same reconstruction as the sampler), which
// resolves lobes narrower than a source texel. rho = 0 (D a delta) returns the source bilinearly sampled at n.
Cubemap brute_force_prefilter(const Cubemap& src, int out_size, double roughness, int subdivisions = 1);

}  // namespace kiln::envmap
