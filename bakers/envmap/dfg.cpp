#include "bakers/envmap/dfg.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "bakers/brdf/bxdf.h"

namespace kiln::envmap {

brdf::ModelSpec lobe_at_roughness(brdf::ModelSpec lobe, double rho) {
  switch (lobe.model) {
    case brdf::Model::ggx:
    case brdf::Model::beckmann:
    case brdf::Model::cook_torrance:
      lobe.alpha_x = lobe.alpha_y = rho * rho;
      break;
    case brdf::Model::schlick:
    case brdf::Model::schlick_double:
      lobe.layer.r = rho * rho * rho * rho;
      break;
    case brdf::Model::oren_nayar:
    case brdf::Model::oren_nayar_simple:
    case brdf::Model::lambert:
      break;  // diffuse lobes have no specular roughness to map
  }
  return lobe;
}

DfgEntry dfg_entry(const brdf::ModelSpec& lobe, double mu, double rho, const brdf::AlbedoOptions& options) {
  const auto bxdf = brdf::make_bxdf(brdf::without_fresnel(lobe_at_roughness(lobe, rho)));
  return brdf::split_sum_entry(*bxdf, mu, options);
}

double DfgTable::max_error() const {
  double m = 0;
  for (const DfgEntry& e : entries) m = std::max({m, e.scale_error, e.bias_error, e.energy_error});
  return m;
}

DfgTable compute_dfg(const brdf::ModelSpec& lobe, int size_mu, int size_roughness, const brdf::AlbedoOptions& options) {
  for (const auto& [name, n] : {std::pair{"size_mu", size_mu}, std::pair{"size_roughness", size_roughness}}) {
    if (n < 1 || n > 1024) {
      throw std::invalid_argument(std::string(name) + ": must be in [1, 1024], got " + std::to_string(n));
    }
  }
  if (auto problem = brdf::validate(lobe)) throw problem->under("lobe");
  DfgTable t;
  t.size_mu = size_mu;
  t.size_roughness = size_roughness;
  t.entries.resize(static_cast<size_t>(size_mu) * size_roughness);
  tbb::parallel_for(0, size_mu * size_roughness,
                    [&](int k) { t.entries[k] = dfg_table_entry(lobe, size_mu, size_roughness, options, k); });
  return t;
}

DfgEntry dfg_table_entry(const brdf::ModelSpec& lobe, int size_mu, int size_roughness,
                         const brdf::AlbedoOptions& options, int k) {
  const int i = k % size_mu, j = k / size_mu;
  brdf::AlbedoOptions o = options;
  o.seed = options.seed + static_cast<uint64_t>(k) * 0x9e3779b97f4a7c15ULL;  // independent entries
  return dfg_entry(lobe, (i + 0.5) / size_mu, (j + 0.5) / size_roughness, o);
}

}  // namespace kiln::envmap
