// The split-sum DFG table of an environment bake (Karis 2013): over (μ = n·v, perceptual roughness), the scale and
// bias that a renderer applies to f0, and the single-scattering directional albedo that energy compensation needs
// (Kulla & Conty 2017; Fdez-Agüera 2019: multiply the specular term by 1 + f0 (1/E − 1)).
//
// Roughness axis: perceptual roughness ρ ∈ [0, 1], the one mapping every kiln environment output uses:
//   microfacet lobes (GGX, Beckmann, Cook–Torrance's, and the environment bake's "schlick" lobe, which is the
//   microfacet model with Schlick's rational Beckmann D, lobe.h):  α (or m) = ρ²;
//   Schlick's own BRDF (Model::schlick), whose Z(t) is GGX with α² = r:  r = ρ⁴ (so that α = ρ² again).
#pragma once

#include <vector>

#include "bakers/brdf/albedo.h"
#include "bakers/brdf/model_spec.h"

namespace kiln::envmap {

// The model parameters of `lobe` at perceptual roughness rho (see the mapping above). Lobes without roughness
// (Lambert) are returned unchanged.
brdf::ModelSpec lobe_at_roughness(brdf::ModelSpec lobe, double rho);

// scale, bias and energy (= scale + bias = E(μ) with F = 1), with their standard errors.
using DfgEntry = brdf::SplitSumEntry;

// One entry: the white lobe without Fresnel at (μ, ρ), integrated by its own importance sampling.
DfgEntry dfg_entry(const brdf::ModelSpec& lobe, double mu, double rho, const brdf::AlbedoOptions& options = {});

struct DfgTable {
  int size_mu = 0, size_roughness = 0;
  // Row-major [roughness][mu], texel centres: μ = (i + 0.5) / size_mu, ρ = (j + 0.5) / size_roughness.
  std::vector<DfgEntry> entries;
  const DfgEntry& at(int i_mu, int j_roughness) const { return entries[j_roughness * size_mu + i_mu]; }
  double max_error() const;  // the largest standard error of any channel
};

// Entry k (row-major: k = j_roughness · size_mu + i_mu) of compute_dfg's table, computed alone: every entry has a
// seed of its own, so this gives the table's entry bit for bit.
DfgEntry dfg_table_entry(const brdf::ModelSpec& lobe, int size_mu, int size_roughness,
                         const brdf::AlbedoOptions& options, int k);

// Every entry, in parallel (TBB). Throws std::invalid_argument for sizes outside [1, 1024] or an invalid lobe.
DfgTable compute_dfg(const brdf::ModelSpec& lobe, int size_mu, int size_roughness,
                     const brdf::AlbedoOptions& options = {});

}  // namespace kiln::envmap
