// One entry of the material bake's tables (an albedo at one μ, an average, a split-sum cell), estimated in rounds of
// independent blocks. Rounds are combined by their sample counts (mean = Σ n_k m_k / N, variance =
// Σ (n_k / N)² se_k²), which stays unbiased where an inverse-variance weighting would correlate the weights with the
// noise. Every block of every entry has its own seed, so the rounds are independent and the bake is reproducible.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "bakers/brdf/albedo.h"
#include "bakers/brdf/bxdf.h"
#include "bakers/math/rgb.h"

namespace kiln::material {

constexpr uint64_t kMaxBlock = 65536;  // samples between two cancel checks (a few ms)
constexpr int kReplicates = 8;         // as brdf::AlbedoOptions: 7 degrees of freedom per block

enum class Kind { albedo, white, average, white_average, split_sum };

struct Entry {
  Kind kind = Kind::albedo;
  int i_mu = 0, i_roughness = 0;
  uint64_t requested = 0;  // samples asked for so far (before rounding up to whole replicates)
  uint64_t samples = 0;    // samples taken
  Rgb weighted_sum;        // Σ n_k m_k
  Rgb weighted_variance;   // Σ n_k² se_k²
  double planned = 0;      // samples this entry is expected to need in total (for progress)
  bool done = false;

  Rgb mean() const;
  Rgb std_error() const;
  // Split-sum entries carry scale in r and bias in g; b is unused.
  double error() const;
  void add(const brdf::Estimate& e);
  brdf::Estimate estimate() const;
};

// The models the entries integrate.
struct TableModels {
  std::unique_ptr<brdf::Bxdf> bxdf;               // as configured
  std::unique_ptr<brdf::Bxdf> white;              // the white-furnace form: white, Fresnel off
  std::vector<std::unique_ptr<brdf::Bxdf>> rows;  // the white form at each distinct split-sum roughness
};

// μ at the centre of texel i of n_mu.
inline double mu_at(int i, int n_mu) { return (i + 0.5) * (1.0 / n_mu); }

// A 64-bit mixer: distinct inputs give unrelated seeds.
uint64_t splitmix64(uint64_t x);
// The seed of block `block` of entry `entry`.
uint64_t block_seed(uint64_t seed, uint64_t entry, uint64_t block);
// Samples an estimate of `requested` samples really takes: whole replicates of n×n strata.
uint64_t taken(uint64_t requested);
// Samples taken for `requested` in blocks of at most kMaxBlock.
uint64_t taken_in_blocks(uint64_t requested);

// One block of `samples` samples of entry e, with its own seed.
brdf::Estimate estimate_block(const TableModels& models, const Entry& e, int n_mu, uint64_t samples, uint64_t seed);

}  // namespace kiln::material
