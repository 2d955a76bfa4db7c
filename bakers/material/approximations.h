// The approximations a model uses, each with the exact form to compare against (the material bake measures what
// each costs in albedo).
#pragma once

#include <string>
#include <vector>

#include "bakers/brdf/model_spec.h"

namespace kiln::material {

struct Comparison {
  std::string name;
  // One exact model per channel (the same one three times when the channels agree).
  std::vector<brdf::ModelSpec> exact;  // size 1 or 3
};

// The comparisons for spec; adds a plan line for each approximation that has no exact counterpart here.
std::vector<Comparison> approximations(const brdf::ModelSpec& spec, std::vector<std::string>& plan);

}  // namespace kiln::material
