// The specular prefiltered mip chain of an environment under the split-sum assumption n = v = r (Karis 2013,
// "Real Shading in Unreal Engine 4"): level k holds the environment convolved with the chosen lobe's D weighted by n·l,
//
//     L_pre(n) = ∫ L(l) D(h) (n·l) dω_l / W,    W = ∫ D(h) (n·l) dω_l,    h = (n + l)/|n + l|,
//
// normalised by the integral of the weights (so a constant environment stays exactly that constant). The lobes (GGX,
// Beckmann, Schlick's rational Beckmann; Cook–Torrance's is Beckmann's) and W are in lobe.h.
// Why D(h)(n·l): sampling h from D(h)(n·h) (bakers/brdf's samplers: GGX visible normals seen from v = n, Heitz 2018,
// which is D(h)(n·h) there; Beckmann's and Schlick's D(h)(n·h) directly) and reflecting v about h gives l with density
// p(l) = D(h)(n·h)/(4 v·h) = D(h)/4, so Karis's estimator Σ L(l_i)(n·l_i) / Σ (n·l_i) converges to the ratio above.
//
// ## Roughness of each level (the one mapping)
// Level k of L levels has perceptual roughness ρ_k = k/(L − 1) (level 0 = mirror, the last level ρ = 1), and the
// lobe's width is α = ρ² (lobe.h, dfg.h). Level k has size max(1, out_size >> k) (a mip chain).
//
// ## The sun (sun.h)
// The chain is computed from a sky/sun split: the sky is importance sampled, the sun texels are summed exactly at every
// output texel with the same normalisation W, so sky + sun converges to the convolution of the whole map. Level 0 (the
// mirror) is the sky's mip of that size with the sun texels' power deposited back (exactly the source at its size).
//
// ## Filtered importance sampling (Křivánek & Colbert 2008, GPU Gems 3 ch. 20)
// Each sample reads the sky's own mip chain (built with downsample_2x) at
//     lod = ½ log2(Ω_s/Ω_p) + 1,   Ω_s = 1/(N p(l)),   Ω_p = 4π/(6 size0²),
// clamped to [0, last source level], trilinear (bilinear on each face with seamless edges, linear between levels).
//
// ## Error estimate (honest: noise and filtering bias)
// The N samples are 4 groups of N/4: each group is the same N/4-point Hammersley set with its own Cranley–Patterson
// rotation (a pseudo-random shift per group from the seed, the same for every texel, so the output has no per-texel
// noise). noise_estimate is the relative RMS over all texels of the standard error of the 4 group means.
// Filtered importance sampling also blurs (bias), which the groups cannot see. So each level is also CHECKED: at a
// stratified subset of texels (all texels of faces up to 8², else a 4 × 4 grid per face: 96) the estimate is compared
// with a brute-force convolution of the sky (every texel of the sky mip of size ≥ min(size0, 16/α), whose box filter
// is ≤ 1/16 of the lobe's width) plus the same exact sun. checked_error is relative_rms_error (below) over the subset,
// error_estimate = max(checked_error, noise_estimate).
//
// ## Relative RMS error (the one definition: reports, targets, tests and the benchmark)
//     e = sqrt( mean_i |v_i − ref_i|² / max(|ref_i|², (0.01 · RMS_i |ref_i|)²) )      (RGB vector norms)
// i.e. each texel's error relative to its own value, except that texels darker than 1/100 of the level's RMS value
// are measured against that floor (a relative error of a near-black texel, e.g. below a lit horizon, means nothing
// and would otherwise dominate).
// tests/envmap/prefilter_test.cpp shows that error_estimate is within a factor 3 of the error measured against a
// full brute-force convolution.
//
// ## Samples from a target error
// samples = 0 chooses N per level: starting from 64, the checked error e(N) of the subset is measured and N is scaled
// by (e/target)² × 1.2 (the 1/√N law of noise; the bias of filtered importance sampling and the QMC noise fall
// faster, so the law overestimates N rather than under) until the target is bracketed between a failing and a
// passing N, which are then bisected geometrically (within 50 %), at most 6 trials in all; the smallest N that met
// the target is kept, within [16, 65536] (a multiple of 4). A level at the cap that still misses the target reports
// its larger error.
#pragma once

#include <atomic>
#include <cstdint>
#include <vector>

#include "bakers/brdf/model_spec.h"
#include "bakers/envmap/cubemap.h"

namespace kiln::envmap {

struct SunTexel;

struct PrefilterOptions {
  int levels = 6;     // L ≥ 1; level k has ρ = k/(L − 1)
  int samples = 64;   // N per texel for levels k ≥ 1, rounded up to a multiple of 4; 0: chosen from target_error
  double target_error = 0.01;  // relative RMS error per level aimed at when samples = 0, in (0, 1]
  brdf::Distribution distribution = brdf::Distribution::ggx;
  uint64_t seed = 0;  // the Cranley–Patterson shifts; the same seed gives the same bytes
  // Set (by another thread) to stop early: the chain returned is then incomplete and must be discarded; the caller
  // checks the flag after the call (environment_bake throws bake::BakeCancelled).
  const std::atomic<bool>* cancel = nullptr;
};

inline constexpr int kMinAutoSamples = 16;
inline constexpr int kMaxSamples = 65536;

struct PrefilteredLevel {
  double roughness = 0;       // perceptual ρ; α = ρ²
  Cubemap cube;               // size max(1, out_size >> k)
  double error_estimate = 0;  // max(checked_error, noise_estimate); 0 for level 0 (no sampling)
  double noise_estimate = 0;  // relative RMS standard error over all texels (integration noise only)
  double checked_error = 0;   // relative RMS error against brute force on the checked subset (noise and bias)
  int checked_texels = 0;     // how many texels were checked
  int samples = 0;            // N per texel used (0 for level 0)
  int pilot_samples = 0;      // samples spent per checked texel choosing N (all trials)
  double seconds = 0;         // wall time of the level, choice of N and check included
};

// Perceptual roughness of level k of `levels` (ρ_k = k/(L − 1); a single level is the mirror, ρ = 0).
double prefilter_level_roughness(int level, int levels);

// The whole chain from a sky and its sun (sun.h; an empty sun: the sky is the whole map), in parallel (TBB) over
// output texels. Throws std::invalid_argument for out_size < 1, levels < 1, samples < 0, a target error outside
// (0, 1] or an empty source.
std::vector<PrefilteredLevel> prefilter_specular(const Cubemap& sky, const std::vector<SunTexel>& sun, int out_size,
                                                 const PrefilterOptions& options = {});
// The same without a sun: the whole `source` is importance sampled.
std::vector<PrefilteredLevel> prefilter_specular(const Cubemap& source, int out_size,
                                                 const PrefilterOptions& options = {});

inline constexpr double kRelativeErrorFloor = 0.01;
// e above over all texels of two cubes of the same size (throws std::invalid_argument otherwise).
double relative_rms_error(const Cubemap& value, const Cubemap& reference);

// The source mip chain used by filtered importance sampling: source, then downsample_2x while the size is even.
std::vector<Cubemap> build_source_mips(const Cubemap& source);

// Reference: the same normalised lobe summed over every source texel with exact solid angles,
//     L_ref(n) = Σ_texels L_j D(h_j)(n·l_j) Ω_j / Σ_texels D(h_j)(n·l_j) Ω_j.
// With subdivisions k > 1 every texel is split into k × k sub-texels, each with its own exact solid angle
// (face_rect_solid_angle) and its radiance read with sample_bilinear (the same reconstruction as the sampler), which
// resolves lobes narrower than a source texel. rho = 0 (D a delta) returns the source bilinearly sampled at n.
// In parallel (TBB) over output texels.
Cubemap brute_force_prefilter(const Cubemap& src, int out_size, double roughness, brdf::Distribution distribution,
                              int subdivisions = 1);
// GGX.
Cubemap brute_force_prefilter(const Cubemap& src, int out_size, double roughness, int subdivisions = 1);

}  // namespace kiln::envmap
