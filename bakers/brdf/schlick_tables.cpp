#include "bakers/brdf/schlick_tables.h"

#include <utility>

#include "bakers/bake/bounded_cache.h"
#include "bakers/math/constants.h"

namespace kiln::brdf::detail {

// (1/π) ∫ value(w) cos θ dω over the hemisphere, of the interpolant itself, so that quantities built on it balance
// exactly: Gauss in every cell, in x and in φ (the interpolant is a cubic in x and in s = sin φ there; μ(x) and
// sin φ are smooth).
double DirectionTable::cosine_average() const {
  const QuadratureRule& g = unit_rule(4);
  double sum = 0;
  const int cells_s = n_s_ == 1 ? 1 : n_s_ - 1;
  for (int cs = 0; cs < cells_s; ++cs) {
    const double phi0 = n_s_ == 1 ? 0.0 : phi_node(cs), phi1 = n_s_ == 1 ? kPiOver2 : phi_node(cs + 1);
    for (size_t is = 0; is < g.nodes.size(); ++is) {
      const double phi = phi0 + (phi1 - phi0) * g.nodes[is];
      const double wphi = g.weights[is] * (phi1 - phi0) / kPiOver2;  // fraction of the quarter turn
      const double sp = std::sin(phi);
      for (int cx = 0; cx < n_mu_ - 1; ++cx) {
        for (size_t ix = 0; ix < g.nodes.size(); ++ix) {
          const double x = (cx + g.nodes[ix]) / (n_mu_ - 1);
          const double wx = g.weights[ix] / (n_mu_ - 1);
          sum += wphi * wx * lookup_xs(x, sp) * mu_of_x(x) * dmu_dx(x);
        }
      }
    }
  }
  // (1/π) ∫_0^2π dφ ∫ E μ dμ = 2 × (mean over φ of ∫ E μ dμ).
  return 2.0 * sum;
}

std::shared_ptr<const LayerTables> cached_tables(double r, double p, const std::function<LayerTables()>& build) {
  static bake::BoundedCache<std::pair<double, double>, LayerTables> cache(256);
  return cache.get(std::make_pair(r, p), build);
}

}  // namespace kiln::brdf::detail
