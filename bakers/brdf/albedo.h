// What the material bake returns: directional albedo E(μ) = ∫ f(wo, wi) cos θ_i dω_i, the average albedo
// E_avg = 2 ∫ E(μ) μ dμ, and the split-sum table (scale and bias on f0). Every estimate comes with its standard error.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "bakers/brdf/bxdf.h"
#include "bakers/brdf/model_spec.h"
#include "bakers/math/rng.h"

namespace kiln::brdf {

struct AlbedoOptions {
  int samples = 4096;  // per estimate; rounded up to whole stratified replicates
  int replicates = 8;  // independent stratified sets; their spread gives the standard error
  uint64_t seed = 1;
};

struct Estimate {
  Rgb value;
  Rgb std_error;  // standard error of value, from the spread of the replicates
  int64_t samples = 0;
};

// The estimator behind every function here: `options.replicates` independent sets of n×n jittered strata of the
// lobe's 2-D sample u (n×n ≥ samples / replicates), each set averaged; the spread of the set means gives the
// standard error. `contribution` maps one sample (u, the lobe-selection sample uc, the set's generator for any
// further dimensions) to the value to average. `stream` separates the random streams of different integrals.
using SampleContribution = std::function<Rgb(Point2 u, double uc, Pcg32& rng)>;
Estimate stratified_estimate(const AlbedoOptions& options, uint64_t stream, const SampleContribution& contribution);
// The samples stratified_estimate takes for these options: whole replicates of n×n strata.
int64_t stratified_sample_count(const AlbedoOptions& options);

// E for the fixed outgoing direction wo (wo.z > 0), by the model's own importance sampling, stratified.
Estimate directional_albedo(const Bxdf& bxdf, const Vec3& wo, const AlbedoOptions& options = {});
// E(μ) averaged over the azimuth of wo (the same as any azimuth for an isotropic model), μ = cos θ_o ∈ (0, 1].
Estimate directional_albedo(const Bxdf& bxdf, double mu, const AlbedoOptions& options = {});

struct AlbedoTable {
  std::vector<double> mu;   // texel centres (i + 0.5) / n
  std::vector<Estimate> e;  // E(mu[i])
  Estimate average;         // E_avg = 2 ∫ E(μ) μ dμ
};
AlbedoTable albedo_table(const Bxdf& bxdf, int n_mu, const AlbedoOptions& options = {});

// One split-sum entry of a white lobe without Fresnel at μ = cos θ_o (azimuth of wo averaged): with Schlick's weight
// c = (1 − wo·wh)^5, scale = ∫ f (1 − c) cos θ_i dω_i, bias = ∫ f c cos θ_i dω_i, and energy = scale + bias, the
// lobe's directional albedo, all from the same samples.
struct SplitSumEntry {
  double scale = 0, bias = 0, energy = 0;
  double scale_error = 0, bias_error = 0, energy_error = 0;  // standard errors
  int64_t samples = 0;
};
SplitSumEntry split_sum_entry(const Bxdf& white_lobe, double mu, const AlbedoOptions& options = {});

// Split-sum table over (μ = n·v, roughness) with texel centres on both axes. For each entry the model is built
// white and without its Fresnel term, and its albedo is split by Schlick's weight c = (1 − wo·wh)^5:
//   scale = ∫ f (1 − c) cos θ_i dω_i,  bias = ∫ f c cos θ_i dω_i,  so that E ≈ f0 · scale + bias.
// The roughness axis is the model's own roughness parameter (roughness_name()), with its extent given here.
struct SplitSumTable {
  int n_mu = 0, n_roughness = 0;
  std::vector<double> mu, roughness;
  std::vector<double> scale, bias, scale_error, bias_error;  // row-major: [roughness][mu]
  double at_scale(int i_roughness, int i_mu) const { return scale[i_roughness * n_mu + i_mu]; }
  double at_bias(int i_roughness, int i_mu) const { return bias[i_roughness * n_mu + i_mu]; }
};
SplitSumTable split_sum_table(const ModelSpec& spec, int n_mu, int n_roughness, const AlbedoOptions& options = {});
// The model with the same shape, white (albedo, f0, C = 1) and with Fresnel off: what the split sum integrates.
ModelSpec without_fresnel(ModelSpec spec);
// The extent of the roughness axis: (0, 1] for α and r, [0, 1] rad for σ.
double max_roughness(Model m);

}  // namespace kiln::brdf
