#include "bakers/material/approximations.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "bakers/bake/number_format.h"
#include "bakers/brdf/fresnel.h"
#include "bakers/material/model_traits.h"

namespace kiln::material {

std::vector<Comparison> approximations(const brdf::ModelSpec& spec, std::vector<std::string>& plan) {
  std::vector<Comparison> out;
  const auto add = [&](const std::string& name, const brdf::ModelSpec& exact) {
    if (brdf::validate(exact)) return;  // the exact form cannot be built for these parameters
    out.push_back({name, {exact}});
  };
  if (is_microfacet(spec.model)) {
    if (brdf::fresnel_mode(spec) == brdf::FresnelMode::schlick) {
      // The dielectric whose normal reflectance is f0: eta = (1 + √f0) / (1 − √f0). The exact Fresnel accepts
      // eta ≤ 10, i.e. f0 ≤ 0.669; beyond that f0 describes a metal, for which a dielectric is no reference.
      const double f0_max = brdf::f0_from_eta(10.0);
      if (spec.f0.max() <= f0_max) {
        Comparison c{"fresnel: schlick vs exact dielectric (eta from f0 per channel)", {}};
        const bool grey = spec.f0.r == spec.f0.g && spec.f0.g == spec.f0.b;
        for (int ch = 0; ch < (grey ? 1 : 3); ++ch) {
          brdf::ModelSpec exact = spec;
          exact.fresnel = brdf::FresnelMode::exact;
          const double s = std::sqrt(spec.f0[ch]);
          exact.eta = (1.0 + s) / (1.0 - s);
          c.exact.push_back(exact);
        }
        if (std::none_of(c.exact.begin(), c.exact.end(), [](const auto& x) { return brdf::validate(x).has_value(); }))
          out.push_back(std::move(c));
      } else {
        plan.push_back("approximation fresnel schlick vs exact: skipped, f0 " + bake::format_rgb(spec.f0) +
                       " is beyond any dielectric (eta > 10); a metal needs a complex index for its exact Fresnel");
      }
    }
    const brdf::Distribution d = spec.distribution.value_or(
        spec.model == brdf::Model::ggx ? brdf::Distribution::ggx : brdf::Distribution::beckmann);
    if (d == brdf::Distribution::schlick_beckmann) {
      brdf::ModelSpec exact = spec;
      exact.distribution = brdf::Distribution::beckmann;
      add("distribution: schlick rational beckmann vs exact beckmann", exact);
    }
    const brdf::Masking m = spec.masking.value_or(spec.model == brdf::Model::cook_torrance ? brdf::Masking::v_groove
                                                                                           : brdf::Masking::separable);
    if (m == brdf::Masking::separable) {
      brdf::ModelSpec exact = spec;
      exact.masking = brdf::Masking::height_correlated;
      add("masking: separable smith vs height-correlated smith", exact);
    } else if (m == brdf::Masking::schlick) {
      brdf::ModelSpec exact = spec;
      exact.masking = brdf::Masking::separable;
      add("masking: schlick rational G1 vs smith G1 from D (separable)", exact);
    }
    if (spec.normalization == brdf::Normalization::pi) {
      brdf::ModelSpec exact = spec;
      exact.normalization = brdf::Normalization::four;
      add("normalization: pi (survey eq 9) vs 4 (half-vector Jacobian)", exact);
    }
  }
  if (spec.model == brdf::Model::oren_nayar_simple) {
    brdf::ModelSpec exact = spec;
    exact.model = brdf::Model::oren_nayar;
    exact.interreflection = false;
    add("oren-nayar: simplified A/B vs full first-order (C1, C2, C3)", exact);
  }
  return out;
}

std::vector<Comparison> approximations(const brdf::MaterialSpec& spec, std::vector<std::string>& plan) {
  std::vector<Comparison> out;
  for (const auto& [name, lobe] : {std::pair<const char*, const brdf::ModelSpec*>{"diffuse lobe", &spec.diffuse},
                                   {"specular lobe", &spec.specular}}) {
    // A weightless specular lobe (weights, s = 0) is not part of the material: its approximations cost nothing.
    if (lobe == &spec.specular && spec.combine == brdf::Combine::weights && spec.specular_weight == 0) continue;
    std::vector<std::string> lobe_plan;
    for (Comparison c : approximations(*lobe, lobe_plan)) {
      c.name = std::string(name) + ", " + c.name;
      c.lobe = *lobe;
      out.push_back(std::move(c));
    }
    for (const std::string& line : lobe_plan) plan.push_back(std::string(name) + ": " + line);
  }
  return out;
}

}  // namespace kiln::material
