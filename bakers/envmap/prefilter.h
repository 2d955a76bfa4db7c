// The specular prefiltered mip chain of an environment under the split-sum assumption n = v = r (Karis 2013): level k
// of L has perceptual roughness ρ_k = k/(L − 1) (α = ρ², lobe.h), size max(1, out_size >> k), and holds
//
//     L_pre(n) = ∫ L(l) D(h) (n·l) dω_l / W,    W = ∫ D(h) (n·l) dω_l,    h = (n + l)/|n + l|,
//
// so a constant environment stays exactly that constant. The sky is importance sampled with filtered importance
// sampling (Křivánek & Colbert 2008) in 4 randomised groups (level_sampler.h); the sun (sun.h) is summed exactly. Each
// level's error_estimate is max(noise of the groups, error against brute force on a checked subset of texels), and
// samples = 0 chooses N per level to meet target_error. The derivations, the error estimate and the choice of N are
// in docs/ENVIRONMENT.md.
#pragma once

#include <atomic>
#include <cstdint>
#include <vector>

#include "bakers/brdf/model_spec.h"
#include "bakers/envmap/cubemap.h"

namespace kiln::envmap {

struct SunTexel;

inline constexpr double kDefaultLodBias = 1.0;

struct PrefilterOptions {
  int levels = 6;    // L ≥ 1; level k has ρ = k/(L − 1)
  int samples = 64;  // N per texel for levels k ≥ 1, rounded up to a multiple of 4; 0: chosen from target_error
  double target_error = 0.01;  // relative RMS error per level aimed at when samples = 0, in (0, 1]
  brdf::Distribution distribution = brdf::Distribution::ggx;
  uint64_t seed = 0;  // the Cranley–Patterson shifts; the same seed gives the same bytes
  // The b of filtered importance sampling's lod = ½ log2(Ω_s/Ω_p) + b (Křivánek & Colbert 2008 use 1): lower reads
  // finer mips (less blur, more noise). docs/PERFORMANCE.md compares 1 and 0.5.
  double lod_bias = kDefaultLodBias;
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
// (0, 1], a lod bias outside [−4, 4] or an empty source.
std::vector<PrefilteredLevel> prefilter_specular(const Cubemap& sky, const std::vector<SunTexel>& sun, int out_size,
                                                 const PrefilterOptions& options = {});
// The same without a sun: the whole `source` is importance sampled.
std::vector<PrefilteredLevel> prefilter_specular(const Cubemap& source, int out_size,
                                                 const PrefilterOptions& options = {});

// The relative RMS error (the one definition: reports, targets, tests and the benchmark), RGB vector norms:
//     e = sqrt( mean_i |v_i − ref_i|² / max(|ref_i|², (kRelativeErrorFloor · RMS_i |ref_i|)²) )
// each texel's error relative to its own value, except that texels darker than 1/100 of the RMS value are measured
// against that floor (the relative error of a near-black texel means nothing and would otherwise dominate).
inline constexpr double kRelativeErrorFloor = 0.01;
// e over all texels of two cubes of the same size (throws std::invalid_argument otherwise).
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
