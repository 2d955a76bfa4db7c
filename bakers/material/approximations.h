// The approximations a model uses, each with the exact form to compare against (the material bake measures what
// each costs in albedo).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "bakers/brdf/material.h"
#include "bakers/brdf/model_spec.h"

namespace kiln::material {

struct Comparison {
  std::string name;
  // One exact model per channel (the same one three times when the channels agree).
  std::vector<brdf::ModelSpec> exact;  // size 1 or 3
  // For a two-lobe material: the lobe that makes the approximation, measured alone. Unset: the baked model.
  std::optional<brdf::ModelSpec> lobe;
};

// The comparisons for spec; adds a plan line for each approximation that has no exact counterpart here.
std::vector<Comparison> approximations(const brdf::ModelSpec& spec, std::vector<std::string>& plan);
// A two-lobe material's: each lobe's, named "diffuse lobe, ..." or "specular lobe, ..." and carrying its lobe.
std::vector<Comparison> approximations(const brdf::MaterialSpec& spec, std::vector<std::string>& plan);

}  // namespace kiln::material
