// The catalogue of BRDF configurations that the cross-model property tests (sampling, stability, reciprocity,
// energy) run over: every model and every option at a few parameters, each with a name usable as a GoogleTest
// parameter name and what the physics says it should satisfy.
#pragma once

#include <memory>
#include <ostream>
#include <string>
#include <vector>

#include "bakers/brdf/bxdf.h"
#include "bakers/brdf/model_spec.h"

namespace kiln::test {

struct CatalogEntry {
  std::string name;  // letters, digits and '_' only (a valid GoogleTest parameter name), unique
  brdf::ModelSpec spec;
  // The directional albedo of the white, Fresnel-free form (brdf::without_fresnel(spec)) is ≤ 1 at every wo.
  // False for Cook–Torrance with the π normalisation (4/π too bright), the simplified Oren–Nayar (≈1.5% over 1 at
  // grazing angles for σ ≈ 0.2; survey eq 27), Oren–Nayar with the two-bounce term (≈5% over at grazing for ρ = 1)
  // and Schlick's rational Beckmann D paired with the Beckmann Smith Λ (tens of percent over at grazing). These are
  // measured in energy_test.cpp. True means: at this entry's own parameters; the energy test sweeps roughness only for
  // the models whose conservation holds at every roughness (microfacet forms with normalisation 4, Schlick).
  bool energy_conserving = true;
  // f(wo, wi) = f(wi, wo) as configured (Helmholtz reciprocity); every model of the survey is reciprocal.
  bool reciprocal = true;
  // The model depends on the azimuth of wo (α_x ≠ α_y, Schlick's p < 1): tests then vary φo too.
  bool anisotropic = false;
  // The narrowest lobe of the model is sharp (α ≤ 0.1, or Schlick r ≤ 0.01 since r acts as α²): tests use finer
  // resolutions for it.
  bool sharp = false;
  // Differs from an earlier entry only in a term that its importance sampling is not meant to follow (Fresnel,
  // masking, the normalisation constant, η, the interreflection term): the sampling test runs it at fewer angles.
  bool sampling_variant = false;

  std::unique_ptr<brdf::Bxdf> make() const;
};

// Every configuration the property tests run over (about 55 entries).
const std::vector<CatalogEntry>& model_catalog();
// Extreme parameters at the edges of what brdf::validate() accepts, for the stability and reciprocity tests:
// α = 1e-6 and 1, σ = 0 and π/2, η = 1, η → 1, η = 0.1 and 10, f0 = 0 and 1, Schlick's r and p = 0 and 1, black and
// white albedos. Names start with "extreme_".
const std::vector<CatalogEntry>& extreme_catalog();
// The entry with this name in either list; throws std::out_of_range if there is none.
const CatalogEntry& catalog_entry(const std::string& name);

// GoogleTest prints test parameters with PrintTo (found by argument-dependent lookup): the name, not the bytes.
void PrintTo(const CatalogEntry& e, std::ostream* os);
void PrintTo(const CatalogEntry* e, std::ostream* os);

}  // namespace kiln::test
