// The quadrature tables of Schlick's layer model: a function of the outgoing direction tabulated over (μ, |sin φ|),
// what a layer tabulates, and the cache that lets models with the same (r, p) share them (schlick_*.cpp only).
#pragma once

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <vector>

#include "bakers/brdf/schlick_internal.h"
#include "bakers/math/vec3.h"

namespace kiln::brdf::detail {

// A function of wo tabulated over μ = cos θo ∈ [0, 1] and, when the model is anisotropic, over s = |sin φo| ∈ [0, 1].
// Every term of the model depends on the azimuths only through cos² and sin², so E(φ) = E(−φ) = E(π − φ): a quarter
// turn suffices, E is even in s at s = 0 and smooth in s at s = 1 (φ = π/2). Uniform in s, the nodes are about
// uniform in φ near φ = 0, where E changes on a scale of ~0.1 rad at grazing angles when p is small (views along the
// tangent reflect to grazing). μ nodes sit at μ(x) = (e^(λx) − 1) / (e^λ − 1) for x uniform on [0, 1], with λ set so
// that the grid is finer than the masking scale k near grazing, where E bends. Catmull–Rom interpolation in x and s
// (mirror ghost at s = 0, linear extrapolation at the other ends), clamped to [0, 1].
class DirectionTable {
 public:
  DirectionTable() = default;
  DirectionTable(int n_mu, int n_s, double grazing_scale)
      : n_mu_(n_mu), n_s_(n_s), lambda_(std::log1p(1.0 / grazing_scale)), values_(n_mu * n_s, 0.0) {
    expm1_lambda_ = std::expm1(lambda_);
  }

  int n_mu() const { return n_mu_; }
  int n_s() const { return n_s_; }
  double x_node(int j) const { return static_cast<double>(j) / (n_mu_ - 1); }
  double mu_node(int j) const { return mu_of_x(x_node(j)); }
  double s_node(int l) const { return n_s_ == 1 ? 0.0 : static_cast<double>(l) / (n_s_ - 1); }
  double phi_node(int l) const { return std::asin(s_node(l)); }  // in [0, π/2]
  double& at(int j, int l) { return values_[l * n_mu_ + j]; }
  double at(int j, int l) const { return values_[l * n_mu_ + j]; }

  double mu_of_x(double x) const { return std::expm1(lambda_ * x) / expm1_lambda_; }
  double dmu_dx(double x) const { return lambda_ * std::exp(lambda_ * x) / expm1_lambda_; }
  double x_of_mu(double mu) const { return std::log1p(std::min(1.0, mu) * expm1_lambda_) / lambda_; }

  // The value for a direction of the upper hemisphere (w.z > 0).
  double lookup(const Vec3& w) const { return lookup_xs(x_of_mu(w.z), n_s_ == 1 ? 0.0 : std::sqrt(sin2_phi(w))); }

  double lookup_xs(double x, double s) const {
    const double fx = std::clamp(x, 0.0, 1.0) * (n_mu_ - 1);
    const int jx = std::min(n_mu_ - 2, static_cast<int>(fx));
    const double tx = fx - jx;
    if (n_s_ == 1) return std::clamp(cubic_x(jx, tx, 0), 0.0, 1.0);
    const double fs = std::clamp(s, 0.0, 1.0) * (n_s_ - 1);
    const int js = std::min(n_s_ - 2, static_cast<int>(fs));
    const double ts = fs - js;
    const double c1 = cubic_x(jx, tx, js), c2 = cubic_x(jx, tx, js + 1);
    const double c0 = cubic_x(jx, tx, js > 0 ? js - 1 : 1);  // E(−s) = E(s)
    const double c3 = js + 2 < n_s_ ? cubic_x(jx, tx, js + 2) : 2.0 * c2 - c1;
    return std::clamp(catmull_rom(c0, c1, c2, c3, ts), 0.0, 1.0);
  }

  // (1/π) ∫ value(w) cos θ dω over the hemisphere, of the interpolant itself, so that quantities built on it balance
  // exactly.
  double cosine_average() const;

 private:
  static double catmull_rom(double p0, double p1, double p2, double p3, double t) {
    return p1 + 0.5 * t * (p2 - p0 + t * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3 + t * (3.0 * (p1 - p2) + p3 - p0)));
  }
  // Along x, beyond the ends: linear extrapolation from the last two nodes.
  double cubic_x(int jx, double tx, int l) const {
    const double v1 = at(jx, l), v2 = at(jx + 1, l);
    const double v0 = jx > 0 ? at(jx - 1, l) : 2.0 * v1 - v2;
    const double v3 = jx + 2 < n_mu_ ? at(jx + 2, l) : 2.0 * v2 - v1;
    return catmull_rom(v0, v1, v2, v3, tx);
  }

  int n_mu_ = 0, n_s_ = 1;
  double lambda_ = 1.0, expm1_lambda_ = 1.0;
  std::vector<double> values_;
};

// What a layer tabulates. It depends on (r, p) only, not on C.
struct LayerTables {
  DirectionTable e;     // E = albedo of f_ss
  DirectionTable e5;    // (1 − u)^5-weighted albedo of f_ss + f_ms (the double layer's transmission)
  double e_avg = 0;     // Ē = (1/π) ∫ E cos θ dω
  double ms_scale = 0;  // 1 / (π (1 − Ē))
};

// Models with the same (r, p) share their tables: a bake builds a model per material, and anisotropic tables take
// ~10–20 ms to build (isotropic ones under 1 ms). Bounded; the oldest entries go first. Two threads asking for the
// same new entry may both build it; either copy is kept.
std::shared_ptr<const LayerTables> cached_tables(double r, double p, const std::function<LayerTables()>& build);

}  // namespace kiln::brdf::detail
