// What the material bake asks of a model spec beyond building it.
#pragma once

#include <string>

#include "bakers/brdf/model_spec.h"

namespace kiln::material {

inline bool has_roughness(brdf::Model m) { return std::string(brdf::roughness_name(m)) != "none"; }

inline bool is_microfacet(brdf::Model m) {
  return m == brdf::Model::ggx || m == brdf::Model::beckmann || m == brdf::Model::cook_torrance;
}

inline bool anisotropic(const brdf::ModelSpec& s) {
  if (is_microfacet(s.model)) return s.alpha_x != s.alpha_y;
  if (s.model == brdf::Model::schlick) return s.layer.p < 1;
  if (s.model == brdf::Model::schlick_double) return s.layer.p < 1 || s.bottom_layer.p < 1;
  return false;
}

}  // namespace kiln::material
