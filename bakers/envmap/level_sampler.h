// The sampler of one level of the specular chain (prefilter.h): filtered importance sampling (Křivánek & Colbert
// 2008) of the sky's mip chain with a sample pattern that is the same for every texel of the level. Sampling h from
// D(h)(n·h) and reflecting v = n about it gives l with density p(l) = D(h)(n·h)/(4 v·h) = D(h)/4, so
// Σ L(l_i)(n·l_i) / Σ (n·l_i) converges to L_pre. Each sample reads the sky's mips trilinearly at
// lod = ½ log2(Ω_s/Ω_p) + b (b = 1 by default, PrefilterOptions::lod_bias), Ω_s = 1/(N p(l)), Ω_p = 4π/(6 size0²). The
// N samples are 4 groups of N/4: the same Hammersley set, each group with its own Cranley–Patterson shift from the seed
// (the same for every texel, so the output has no per-texel noise); the spread of the group means is the noise
// estimate.
//
// Why lanes: the pattern being shared, kSamplerLanes texels are evaluated together, one sample at a time for all of
// them. The pattern is stored as arrays (structure of arrays), and the loop over lanes that turns a sample into
// face coordinates and bilinear taps is branch-free, so the compiler vectorises it; neighbouring texels also read
// neighbouring source texels for the same sample, which keeps them in cache. Every lane does the arithmetic of a
// single texel's scalar evaluation in the same order (Cubemap::sample_bilinear's reads, direction_to_face_uv's
// comparisons), so the values do not depend on the lanes: the same bytes as one texel at a time.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "bakers/brdf/model_spec.h"
#include "bakers/envmap/cubemap.h"

namespace kiln::envmap {

inline constexpr int kSamplerGroups = 4;  // independent randomised groups for the noise estimate
inline constexpr int kSamplerLanes = 8;   // texels evaluated together

// The sky's mip chain as the sampler reads it: each level's six faces in one array, each face with a one-texel border
// holding what Cubemap::texel_extended gives beyond its edges, so that a bilinear read is four loads without a
// branch. Reads are bit for bit those of Cubemap::sample_bilinear (the same texels, the same arithmetic).
class PaddedMips {
 public:
  struct Level {
    int size = 0, stride = 0, face_stride = 0;  // stride = size + 2, face_stride = stride²
    std::vector<Rgb> texels;                    // face-major, then row-major, border included
  };
  explicit PaddedMips(const std::vector<Cubemap>& mips);
  int count() const { return static_cast<int>(levels_.size()); }
  const Level& level(int m) const { return levels_[m]; }

 private:
  std::vector<Level> levels_;
};

class LevelSampler {
 public:
  // The pattern of N = `samples` (rounded up to a multiple of kSamplerGroups) for a lobe of width alpha over mips
  // whose level 0 has faces of size0², reading at lod = ½ log2(Ω_s/Ω_p) + lod_bias.
  LevelSampler(const PaddedMips& mips, int size0, double alpha, brdf::Distribution distribution, int samples,
               uint64_t seed, double lod_bias);

  // The estimates at count ∈ [1, kSamplerLanes] unit normals n[0 .. count) into value[0 .. count), and, unless
  // rel_var is null, their relative squared standard errors (of the average channel) into rel_var[0 .. count).
  void eval(const Vec3* n, int count, Rgb* value, double* rel_var) const;

  // One group's samples: direction l in the local frame (normal +z, so n·l = l.z), and its mip level split into the
  // level below (l0) and the weight t of the one above (t = 0: l0 alone).
  struct Group {
    std::vector<double> lx, ly, lz, t;
    std::vector<int> l0;
    double w = 0.0;  // Σ n·l over the group, in sample order
  };
  // A sampler with a given pattern (each group's w is recomputed from its samples), for tests: l0 must be a level
  // of `mips` and, where t ≠ 0, so must l0 + 1.
  LevelSampler(const PaddedMips& mips, const std::array<Group, kSamplerGroups>& groups);
  const Group& group(int g) const { return groups_[g]; }

 private:
  // One texel's estimate Σ_g sum_g / Σ_g W_g from its group sums, and its relative squared standard error (of the
  // average channel) from the spread of the group means, unless rel_var is null.
  Rgb combine_groups(const std::array<Rgb, kSamplerGroups>& group_sum, double* rel_var) const;

  const PaddedMips& mips_;
  std::array<Group, kSamplerGroups> groups_;
};

}  // namespace kiln::envmap
