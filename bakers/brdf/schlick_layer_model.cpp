#include "bakers/brdf/schlick_layer_model.h"

#include "bakers/math/sampling.h"

namespace kiln::brdf::detail {
namespace {

// r = 0 is a perfect mirror, a Dirac delta: the narrowest lobe kept is α = sqrt(1e-7) ≈ 3e-4 (about 0.02°), whose
// masking scale k ≈ 1.6e-4 the μ grid of the albedo table still resolves. Peak values stay finite (Z(1) = 1e7).
constexpr double kMinRoughness = 1e-7;
// p = 0 puts every normal in the plane perpendicular to the tangent (a delta in azimuth): the narrowest azimuthal
// lobe kept has width ~1e-6 rad, peak A_n ≈ 1e5. Azimuth::integrate maps the peak exactly, so nothing depends on it.
constexpr double kMinIsotropy = 1e-6;

// Resolution of the tables and of the quadrature that fills them (errors measured against an independent quadrature
// during development and in schlick_test). Anisotropic tables cost kAzimuthTableNodes times more: coarser in μ.
constexpr int kMuNodes = 40;                 // table nodes over μ ∈ [0, 1], isotropic
constexpr int kMuNodesAniso = 24;            // the same, anisotropic
constexpr int kAzimuthTableNodes = 9;        // table nodes over |sin φo| ∈ [0, 1], anisotropic
constexpr int kThetaNodes = 16;              // Gauss nodes in θ_h per region (all azimuths visible / part of them)
constexpr int kThetaNodesPiece = 14;         // the same per piece when the partial region is cut at the peaks of A_n
constexpr double kGrazingScale = 1.0 / 6.0;  // the μ grid is ~kGrazingScale·k fine at grazing (E bends there)
constexpr int kSphereMuNodes = 16;           // Gauss nodes over the μ of wi for the diffuse part of E5
constexpr int kSpherePhiNodes = 16;          // midpoint nodes over the azimuth of wi for the same

}  // namespace

SchlickLayerModel::SchlickLayerModel(const SchlickLayer& layer)
    : layer_(layer),
      r_(std::max(layer.r, kMinRoughness)),
      alpha_(std::sqrt(r_)),
      k_(0.5 * alpha_ * (1.0 + alpha_)),
      azimuth_(std::max(layer.p, kMinIsotropy)) {
  // The nodes over the whole turn do not depend on wo: computed once. Isotropic tables are computed at φo = 0,
  // where the integrand is even in φ_h: half a turn, twice the weight.
  if (azimuth_.isotropic()) {
    azimuth_.integrate(0.0, kPi, [this](double c, double s, double w) { circle_nodes_.push_back({c, s, 2.0 * w}); });
  } else {
    azimuth_.integrate(-kPiOver4, 7.0 * kPiOver4, [this](double c, double s, double w) {
      circle_nodes_.push_back({c, s, w});
    });
  }
  if (!azimuth_.isotropic()) {
    cx_ = 0;
    for (const auto& n : circle_nodes_) cx_ += n[2] * n[0] * n[0];
  }
  tables_ = cached_tables(r_, azimuth_.p(), [this] { return build_tables(); });
}

// ∫ f_ss cos θi dωi for the direction wo (and the same weighted by (1 − u)^5, for E5), integrated over the
// normals h with density D(h) t: with ξ the CDF of θ_h and the azimuth weight folded into the nodes,
// f_ss cos θi dωi = G(v) G(v') u / (v' t) × d(probability of h)  (dωi = 4u dω_h).
// Reflections below the horizon (v ≤ 0) carry nothing. For θ_h ≤ (π/2 − θo)/2 every azimuth reflects above the
// horizon; for θ_h ≥ (π/2 + θo)/2 none does; between them the azimuths with cos(φ_h − φo) > c* =
// v'(1 − 2t²) / (2 t sin θo sin θ_h) do. Integrating each piece separately keeps every integrand smooth (the horizon
// is a kink otherwise).
SchlickLayerModel::AlbedoPair SchlickLayerModel::single_scattering_albedo(double mu, double phi_o) const {
  Outgoing o;
  o.mu = mu;
  o.phi_o = phi_o;
  o.so = std::sqrt((1.0 - mu) * (1.0 + mu));
  o.wo = Vec3{o.so * std::cos(phi_o), o.so * std::sin(phi_o), mu};
  o.gv_o = g_over_v(mu, std::sin(phi_o) * std::sin(phi_o));
  AlbedoPair sum;
  // η = 1 − ξ, the probability of normals steeper than θ_h: η(θ) = r / (r + tan²θ), computed without cancellation.
  const double asin_mu = std::asin(mu);
  const double th1 = 0.5 * asin_mu, th2 = kPiOver2 - 0.5 * asin_mu;
  const double tan1 = std::tan(th1), tan2 = std::tan(th2);
  const double eta_a = r_ / (r_ + tan1 * tan1), eta_b = r_ / (r_ + tan2 * tan2);
  add_every_azimuth(o, eta_a, sum);
  add_partial_azimuths(o, eta_a, eta_b, sum);
  return sum;
}

// Region I: η ∈ [η_a, 1], every azimuth. Near η_a the reflections at φ_h − φo = π graze the horizon and G(v) ramps
// up over v ~ k, i.e. over η − η_a ~ k η_a: the variable s = ln(η − η_a + k η_a) resolves that ramp and still
// spreads nodes over the lobe (uniform in η).
void SchlickLayerModel::add_every_azimuth(const Outgoing& o, double eta_a, AlbedoPair& sum) const {
  const QuadratureRule& rule = unit_rule(kThetaNodes);
  const double eps = k_ * eta_a;
  const double s0 = std::log(eps), s1 = std::log(1.0 - eta_a + eps);
  for (size_t i = 0; i < rule.nodes.size(); ++i) {
    const double s = s0 + (s1 - s0) * rule.nodes[i], e = std::exp(s);
    add_normal_angle(o, std::min(1.0, eta_a + e - eps), rule.weights[i] * (s1 - s0) * e, false, sum);
  }
}

// Region II: η ∈ [η_b, η_a], in ln η, which spreads the normals' angles evenly (η ≈ r cot²θ_h away from the lobe).
// The integral over the shrinking azimuth interval behaves like (distance)^(3/2) at both ends, and G ramps there too;
// the smoothstep substitution ln η = l_0 + (l_1 − l_0)(3τ² − 2τ³) makes that smooth for Gauss.
// η_b → 0 at grazing wo: below ln η_a − 32 the normals carry at most e^(−32) of the probability and g ≤ 2/k², under
// 1e-5 even at kMinRoughness, so the range is cut there.
// When A_n has peaks (at φ_h = ±π/2), the ends of the azimuth interval, where g vanishes, cross them at the θ_h with
// c* = ±sin φo, i.e. cot 2θ_h = ∓ sin φo tan θo: a kink rounded over ~p. The range is cut there too.
void SchlickLayerModel::add_partial_azimuths(const Outgoing& o, double eta_a, double eta_b, AlbedoPair& sum) const {
  if (!(eta_a > eta_b && o.so > 0)) return;
  const double la = std::log(eta_a), lb = std::max(std::log(eta_b), la - 32.0);
  double breaks[4] = {lb, lb, lb, la};
  if (azimuth_.peaked()) {
    const double spread = std::atan2(std::fabs(std::sin(o.phi_o)) * o.so, o.mu);  // atan(sin φo tan θo) ∈ [0, θo]
    for (int side = 0; side < 2; ++side) {
      const double th = 0.5 * (kPiOver2 + (side == 0 ? spread : -spread));
      const double tn = std::tan(th);
      breaks[1 + side] = std::clamp(std::log(r_ / (r_ + tn * tn)), lb, la);
    }
  }
  const QuadratureRule& pr = unit_rule(azimuth_.peaked() ? kThetaNodesPiece : kThetaNodes);
  for (int piece = 0; piece < 3; ++piece) {
    if (!(breaks[piece + 1] > breaks[piece])) continue;
    // Near grazing the range spans up to 32 units of ln η; a Gauss rule resolves ~10 of them.
    const int chunks = static_cast<int>(std::ceil((breaks[piece + 1] - breaks[piece]) / 10.0));
    for (int c = 0; c < chunks; ++c) {
      const double l0 = breaks[piece] + (breaks[piece + 1] - breaks[piece]) * c / chunks;
      const double l1 = breaks[piece] + (breaks[piece + 1] - breaks[piece]) * (c + 1) / chunks;
      for (size_t i = 0; i < pr.nodes.size(); ++i) {
        const double tau = pr.nodes[i];
        const double s = tau * tau * (3.0 - 2.0 * tau), ds = 6.0 * tau * (1.0 - tau);
        const double eta = std::exp(l0 + (l1 - l0) * s);
        add_normal_angle(o, eta, pr.weights[i] * (l1 - l0) * ds * eta, true, sum);
      }
    }
  }
}

// The normals at one θ_h (given by η), over every azimuth or, when `partial`, over those that reflect wo above the
// horizon.
void SchlickLayerModel::add_normal_angle(const Outgoing& o, double eta, double weight, bool partial,
                                         AlbedoPair& sum) const {
  const double denom = eta + r_ * (1.0 - eta);
  const double t = std::sqrt(eta / denom), st = std::sqrt(r_ * (1.0 - eta) / denom);
  auto node = [&](double c, double s, double w) {
    const Vec3 h{st * c, st * s, t};
    const double u = dot(o.wo, h);
    const double v = 2.0 * u * t - o.mu;
    if (!(v > 0)) return;
    const Vec3 wi = h * (2.0 * u) - o.wo;
    const double g = v * g_over_v(v, sin2_phi(wi)) * u * o.gv_o / t * w * weight;
    sum.e += g;
    sum.e5 += g * pow5(1.0 - u);
  };
  if (!partial) {
    for (const auto& n : circle_nodes_) node(n[0], n[1], n[2]);
    return;
  }
  const double c_star = o.mu * (1.0 - 2.0 * t * t) / (2.0 * t * o.so * st);
  const double dphi = std::acos(std::clamp(c_star, -1.0, 1.0));
  if (azimuth_.isotropic()) {
    // φo = 0 and the integrand is even in φ_h: half the interval, twice the weight.
    azimuth_.integrate(0.0, dphi, [&](double c, double s, double w) { node(c, s, 2.0 * w); });
  } else {
    azimuth_.integrate(o.phi_o - dphi, o.phi_o + dphi, node);
  }
}

LayerTables SchlickLayerModel::build_tables() const {
  const int n_s = azimuth_.isotropic() ? 1 : kAzimuthTableNodes;
  const int n_mu = azimuth_.isotropic() ? kMuNodes : kMuNodesAniso;
  // The smallest masking constant, k(q = 0) (c_x ≤ 1/2), sets the grazing scale.
  const double scale = kGrazingScale * masking_k(0.0);
  LayerTables t;
  t.e = DirectionTable(n_mu, n_s, scale);
  t.e5 = DirectionTable(n_mu, n_s, scale);
  for (int l = 0; l < n_s; ++l) {
    for (int j = 0; j < n_mu; ++j) {
      const AlbedoPair a = single_scattering_albedo(t.e.mu_node(j), t.e.phi_node(l));
      t.e.at(j, l) = a.e;
      t.e5.at(j, l) = a.e5;
    }
  }
  t.e_avg = t.e.cosine_average();
  // f_ms = (1 − E(wo)) (1 − E(wi)) / (π (1 − Ē)). 1 − Ē > 0 because E < 1 over most of the hemisphere (masking
  // is always > 0 away from the normal); if the tables ever said otherwise there is no energy left to return.
  t.ms_scale = t.e_avg < 1.0 ? kInvPi / (1.0 - t.e_avg) : 0.0;
  add_diffuse_e5(t);
  return t;
}

// E5(wo) = ∫ (1 − u)^5 (f_ss + f_ms) cos θi dωi. The single-scattering part came with E; the diffuse part,
// (1 − E(wo)) / (π (1 − Ē)) ∫ (1 − u)^5 (1 − E(wi)) cos θi dωi, is smooth in wi: Gauss in x(μi) (the table's own
// variable, fine at grazing), midpoint rule in φi (periodic).
void SchlickLayerModel::add_diffuse_e5(LayerTables& t) {
  const QuadratureRule& gx = unit_rule(kSphereMuNodes);
  struct Node {
    Vec3 wi;
    double weight;  // includes 1 − E(wi) and cos θi
  };
  std::vector<Node> nodes;
  nodes.reserve(gx.nodes.size() * kSpherePhiNodes);
  for (size_t ix = 0; ix < gx.nodes.size(); ++ix) {
    const double x = gx.nodes[ix];
    const double mui = t.e.mu_of_x(x), si = std::sqrt((1.0 - mui) * (1.0 + mui));
    const double wmu = gx.weights[ix] * t.e.dmu_dx(x) * mui * (2.0 * kPi / kSpherePhiNodes);
    for (int ip = 0; ip < kSpherePhiNodes; ++ip) {
      const double phi = 2.0 * kPi * (ip + 0.5) / kSpherePhiNodes;
      const double cp = std::cos(phi), sp = std::sin(phi);
      const double ewi = t.e.lookup_xs(x, std::fabs(sp));
      nodes.push_back({Vec3{si * cp, si * sp, mui}, wmu * (1.0 - ewi)});
    }
  }
  for (int l = 0; l < t.e5.n_s(); ++l) {
    for (int j = 0; j < t.e5.n_mu(); ++j) {
      const double mu = t.e5.mu_node(j), phi_o = t.e5.phi_node(l);
      const double so = std::sqrt((1.0 - mu) * (1.0 + mu));
      const Vec3 wo{so * std::cos(phi_o), so * std::sin(phi_o), mu};
      double sum = 0;
      for (const Node& n : nodes) {
        // u = wo·h = cos of half the angle between wo and wi.
        const double u = std::sqrt(std::max(0.0, 0.5 * (1.0 + dot(wo, n.wi))));
        sum += n.weight * pow5(1.0 - u);
      }
      t.e5.at(j, l) += t.ms_scale * (1.0 - t.e.at(j, l)) * sum;
    }
  }
}

}  // namespace kiln::brdf::detail
