// What the material bake asks of a model spec beyond building it.
#pragma once

#include <string>

#include "bakers/brdf/model_spec.h"
#include "bakers/material/material_bake.h"

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

inline bool anisotropic(const MaterialBakeInput& in) {
  if (in.material) return anisotropic(in.material->diffuse) || anisotropic(in.material->specular);
  return anisotropic(in.model);
}

// The model whose roughness the split-sum rows sweep: the model itself, or a two-lobe material's specular lobe.
inline const brdf::ModelSpec& split_sum_lobe(const MaterialBakeInput& in) {
  return in.material ? in.material->specular : in.model;
}

}  // namespace kiln::material
