// Schlick 1994, "An Inexpensive BRDF Model for Physically-based Rendering", in an energy-conserving form.
//
// Single layer (C, r, p), local frame with the normal along +z; t = n·h, u = wo·h, v = n·wi, v' = n·wo,
// w = cos of the azimuth of h from the tangent x:
//
//   f(wo, wi) = S(u) [f_ss + f_ms]
//   S(u)   = C + (1 − C)(1 − u)^5                              (survey eq 18)
//   f_ss   = G(wi) G(wo) Z(t) A_n(w) / (4π v v')               (Schlick's microfacet term: single scattering)
//   f_ms   = (1 − E(wo)) (1 − E(wi)) / (π (1 − Ē))             (the energy masking removed, given back diffusely)
//   Z(t)   = r / (1 + r t² − t²)²                              (eq 24; Z/π is GGX with α² = r: ∫ Z t dω_h = π)
//   A_n(w) = A(w) AGM(1, p) / sqrt(p),  A(w) = sqrt(p / (p² − p² w² + w²))   (eq 24, normalised)
//   G(w)   = v / (k − k v + v),  k = α_w (1 + α_w) / 2,  α_w² = 2 r (c_x cos²φ_w + (1 − c_x) sin²φ_w)
//   E(wo)  = ∫ f_ss cos θi dωi, tabulated over μ = cos θo (and sin φo when p < 1); Ē = (1/π) ∫ E cos θ dω.
//   c_x    = the mean of cos²φ_h under A_n (1/2 for p = 1, so that α_w = α = sqrt(r)).
//
// Where and why this departs from the survey's printed eq 22–24 (see also SEED-NOTES.md):
// - Eq 23's second term (1 − G G') / (4π v v') is replaced by f_ms (Kelemen & Szirmay-Kalos 2001, Kulla & Conty
//   2017). As printed its albedo grows like 1/(2 v') at grazing angles and r = 1 is not Lambertian. With f_ms the
//   albedo of f_ss + f_ms is E(wo) + (1 − E(wo)) = 1 exactly (up to the tables' error), so with C = 1 nothing is lost
//   or created, and C ≤ 1 gives albedo ≤ 1 (S ≤ 1). At r = 1 and p = 1 (k = 1, G = v, Z = 1): f_ss = 1/(4π),
//   E = 1/4, f_ms = 3/(4π), so f = 1/π: Lambertian.
// - The masking constant k. Schlick's paper uses k = r. With Z's width α = sqrt(r) that masks far too little: E
//   reaches 8 at v' = 0.001 for r = 0.001 and exceeds 1 for r ≲ 0.1 at grazing angles (measured by brute-force
//   quadrature), which would make 1 − E, hence f_ms, negative. Schlick's own derivation of G (survey eq 19) scales k
//   with the rms slope, i.e. with sqrt(r); k = α/2 is the usual fit of Smith's G1 for GGX (Karis 2013), and the
//   factor (1 + α) brings k to 1 at r = 1, where G(v) = v keeps r = 1 Lambertian. For p < 1 the normals crowd into
//   the plane perpendicular to the tangent: masking along the tangent (a view along the grooves) is weaker and across
//   it stronger, so α is replaced by the rms slope projected on the plane of incidence, α_w. With an isotropic k,
//   E exceeded 1 (≈ 1.1) at grazing views across the grooves for small r and p; with α_w, E ≤ 1/(1 + r) everywhere
//   (measured over r, p, μ and φo; schlick_test's white furnace would show any excess, since the tables clamp E at
//   1). G(wi) G(wo) stays a symmetric product: reciprocal.
// - A(w) averages sqrt(p) / AGM(1, p) over the azimuth, not 1 (a complete elliptic integral of the first kind), so it
//   is divided by that mean: D(h) = Z(t) A_n(w) / π is then a normalised distribution of normals for every p.
// - r = 0 (a perfect mirror: a Dirac delta, which no function holds) is represented by kMinRoughness and p = 0 (a
//   delta in the azimuth of h) by kMinIsotropy: the narrowest lobes whose tables stay accurate. describe() reports
//   the values asked for.
//
// Double layer: f = f_top + T(wo) T(wi) f_bottom, T = 1 − E_top per channel, where E_top(w) = C + (1 − C) E5(w) is
// the full albedo of the top layer (E5 = ∫ (1 − u)^5 (f_ss + f_ms) cos θi dωi; the C part integrates to 1). Light
// reaches the bottom through the top and leaves through it again; the light that the top's underside reflects back
// down (interreflection between the layers) is neglected, so some energy is lost (measured in schlick_test). This
// replaces the survey's eq 25, S D + (1 − S(u)) S' D', whose weight 1 − S(u) is the transmission at one angle only
// and does not bound the albedo by 1. Here the albedo is ≤ A_top + T(wo) A_bottom ≤ 1, and the sum is reciprocal.
//
// Sampling: single layer, with probability E(wo) the microfacet term (θ_h from GGX with α = sqrt(r), φ_h exactly from
// A_n by inverting its CDF, an incomplete elliptic integral, with the Jacobi amplitude; wi = reflect(wo, h)),
// otherwise a cosine-weighted direction; the pdf is the mixture. Double layer: the top or the bottom layer with
// probability proportional to their expected contributions at wo.
#include "bakers/brdf/schlick.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <utility>
#include <vector>

#include "bakers/bake/number_format.h"
#include "bakers/brdf/fresnel.h"
#include "bakers/math/constants.h"
#include "bakers/math/quadrature.h"

namespace kiln::brdf {
namespace {

// r = 0 is a perfect mirror, a Dirac delta: the narrowest lobe kept is α = sqrt(1e-7) ≈ 3e-4 (about 0.02°), whose
// masking scale k ≈ 1.6e-4 the μ grid of the albedo table still resolves. Peak values stay finite (Z(1) = 1e7).
constexpr double kMinRoughness = 1e-7;
// p = 0 puts every normal in the plane perpendicular to the tangent (a delta in azimuth): the narrowest azimuthal
// lobe kept has width ~1e-6 rad, peak A_n ≈ 1e5. The quadrature below maps the peak exactly, so nothing depends on it.
constexpr double kMinIsotropy = 1e-6;
// Below this p the peaks of A_n (width ~p) are integrated in a variable that flattens them; above it A_n varies at
// most by a factor 1/p ≤ 2 and smoothly, and plain Gauss–Legendre panels suffice.
constexpr double kPeakedIsotropy = 0.5;

// Resolution of the tables and of the quadrature that fills them (errors measured against an independent quadrature
// during development and in schlick_test). Anisotropic tables cost kAzimuthTableNodes times more: coarser in μ.
constexpr int kMuNodes = 40;          // table nodes over μ ∈ [0, 1], isotropic
constexpr int kMuNodesAniso = 24;     // the same, anisotropic
constexpr int kAzimuthTableNodes = 9;  // table nodes over |sin φo| ∈ [0, 1], anisotropic
constexpr int kThetaNodes = 16;       // Gauss nodes in θ_h per region (all azimuths visible / part of them)
constexpr int kThetaNodesPiece = 14;  // the same per piece when the partial region is cut at the peaks of A_n
constexpr int kAzimuthNodes = 8;      // Gauss nodes per azimuth panel (a quarter turn at most)
constexpr int kPeakEdgeNodes = 6;     // Gauss nodes in the outer pieces of a peak panel
constexpr int kPeakCoreNodes = 4;     // Gauss nodes in the flat core of a peak panel
constexpr double kGrazingScale = 1.0 / 6.0;  // the μ grid is ~kGrazingScale·k fine at grazing (E bends there)
constexpr int kSphereMuNodes = 16;   // Gauss nodes over the μ of wi for the diffuse part of E5
constexpr int kSpherePhiNodes = 16;  // midpoint nodes over the azimuth of wi for the same

// Gauss–Legendre rules on [0, 1] with 1 to 32 nodes, built once (the constructor of a model must stay cheap).
const QuadratureRule& unit_rule(int n) {
  static const std::array<QuadratureRule, 33> rules = [] {
    std::array<QuadratureRule, 33> r;
    for (int i = 1; i <= 32; ++i) r[i] = gauss_legendre(i, 0.0, 1.0);
    return r;
  }();
  return rules[std::clamp(n, 1, 32)];
}

double pow5(double x) {
  const double x2 = x * x;
  return x2 * x2 * x;
}

// ---------------------------------------------------------------------------------------------------------------
// The normalised azimuthal factor A_n(φ) = AGM(1, p) / sqrt(cos²φ + p² sin²φ), a density A_n / (2π) over φ.
// Its CDF over a quarter turn is F(φ | m) / K(m), m = 1 − p² (incomplete / complete elliptic integrals of the first
// kind); it is sampled exactly by the Jacobi amplitude am(ξ K | m), computed by the AGM scale (Abramowitz & Stegun
// 16.4), whose ratios c_n / a_n depend on p only and are kept here.
class Azimuth {
 public:
  explicit Azimuth(double p) : p_(p) {
    double a = 1.0, b = p, c = std::sqrt((1.0 - p) * (1.0 + p));
    // Quadratic convergence: c_n / a_n falls below 1e-17 in at most ~7 steps for p ≥ kMinIsotropy.
    while (c > 1e-17 * a && levels_ + 1 < static_cast<int>(ratio_.size())) {
      const double an = 0.5 * (a + b), bn = std::sqrt(a * b), cn = 0.5 * (a - b);
      a = an, b = bn, c = cn;
      ratio_[++levels_] = c / a;
    }
    agm_ = a;
    s_edge_ = s_of_delta(kPiOver4);
  }

  double p() const { return p_; }
  // The peak-panel variable of integrate(): tan(δ/2) = (p/2) sinh s.
  double s_of_delta(double delta) const { return std::asinh(2.0 * std::tan(0.5 * delta) / p_); }
  double agm() const { return agm_; }
  bool isotropic() const { return p_ == 1.0; }
  // A_n has peaks narrow enough to need their own treatment in integrate().
  bool peaked() const { return p_ < kPeakedIsotropy; }

  // A_n for a half vector with tangent-plane components (hx, hy).
  double factor(double hx, double hy) const {
    if (isotropic()) return 1.0;
    // hypot and the division keep (cos φ, sin φ) accurate even when hx, hy are tiny enough for their squares to
    // underflow.
    const double rho = std::hypot(hx, hy);
    // h along the normal: w is undefined (the limit depends on the direction of approach); this single direction
    // has measure zero, and the azimuthal mean 1 keeps D continuous in the mean.
    if (!(rho > 0)) return 1.0;
    return factor_of_angle(hx / rho, hy / rho);
  }
  double factor_of_angle(double c, double s) const {
    return isotropic() ? 1.0 : agm_ / std::sqrt(c * c + p_ * p_ * s * s);
  }

  // φ with density A_n(φ) / (2π) from ξ ∈ [0, 1), as (cos φ, sin φ). Each quarter turn holds probability 1/4; odd
  // quarters are mirrored so that every quarter starts where A_n is smallest (φ = 0 or π).
  void sample(double xi, double* cos_phi, double* sin_phi) const {
    const double q4 = 4.0 * xi;
    const int quarter = std::min(3, std::max(0, static_cast<int>(q4)));
    const double f = q4 - quarter;  // fraction of the quarter's probability
    // am(f K | m): φ_N = 2^N a_N f K = 2^(N−1) π f, then back through φ_(n−1) = (φ_n + asin(c_n/a_n sin φ_n)) / 2.
    double psi = std::ldexp(kPi * f, levels_ - 1);
    for (int n = levels_; n >= 1; --n) psi = 0.5 * (psi + std::asin(ratio_[n] * std::sin(psi)));
    const double c = std::cos(psi), s = std::sin(psi);
    switch (quarter) {
      case 0: *cos_phi = c, *sin_phi = s; break;     // φ = ψ
      case 1: *cos_phi = -c, *sin_phi = s; break;    // φ = π − ψ
      case 2: *cos_phi = -c, *sin_phi = -s; break;   // φ = π + ψ
      default: *cos_phi = c, *sin_phi = -s; break;   // φ = 2π − ψ
    }
  }

  // Calls node(cos φ, sin φ, weight) for quadrature nodes over [lo, hi] (hi − lo ≤ 2π) whose weights include the
  // density A_n / (2π): Σ weight g(φ) ≈ ∫_lo^hi g(φ) A_n(φ) / (2π) dφ. The interval is cut at π/4 + k π/2 into
  // quarter-turn panels centred on kπ/2. Where A_n is smooth (p ≥ kPeakedIsotropy, or panels centred on 0 and π,
  // where A_n varies by at most √2) the variable is φ. Panels centred on a peak (k odd) use s with
  // tan(δ/2) = (p/2) sinh s, δ = φ − kπ/2: s is δ/p at the peak and ln tan(δ/2) away from it, the two shapes of
  // A_n dδ, and A_n dδ = AGM cosh s / sqrt(sinh²s + (1 − τ²)²) ds with τ = tan(δ/2): within a few percent of AGM ds
  // at p = 1/2 and closer for smaller p, smooth and nearly flat whatever p. The shape of the integrand away from the
  // peak (|δ| ~ 1) lives in the last few units of s, so the s range is cut there into its own panels.
  template <class Node>
  void integrate(double lo, double hi, Node&& node) const {
    const QuadratureRule& rule = unit_rule(kAzimuthNodes);
    int k = static_cast<int>(std::floor((lo - kPiOver4) / kPiOver2)) + 1;  // panel [π/4 + (k−1)π/2, π/4 + kπ/2]
    double a = lo;
    while (a < hi) {
      const double b = std::min(hi, kPiOver4 + k * kPiOver2);
      const double centre = k * kPiOver2;
      const int km = ((k % 4) + 4) % 4;
      if (b > a) {
        if ((km & 1) && peaked()) {
          const double s0 = s_of_delta(a - centre), s1 = s_of_delta(b - centre);
          // Cuts at ±(s_edge − 4): inside them |δ| ≲ 2 tan(π/8) e^(−4) ≈ 0.015, where the integrand is flat.
          const double cut = std::max(0.0, s_edge_ - 4.0);
          double breaks[4] = {s0, std::clamp(-cut, s0, s1), std::clamp(cut, s0, s1), s1};
          for (int piece = 0; piece < 3; ++piece) {
            const double x0 = breaks[piece], x1 = breaks[piece + 1];
            if (!(x1 > x0)) continue;
            const QuadratureRule& pr = unit_rule(piece == 1 ? kPeakCoreNodes : kPeakEdgeNodes);
            for (size_t i = 0; i < pr.nodes.size(); ++i) {
              const double sv = x0 + (x1 - x0) * pr.nodes[i];
              const double ex = std::exp(sv), sh = 0.5 * (ex - 1.0 / ex), ch = 0.5 * (ex + 1.0 / ex);
              const double tau = 0.5 * p_ * sh, tau2 = tau * tau;
              const double sd = 2.0 * tau / (1.0 + tau2), cd = (1.0 - tau2) / (1.0 + tau2);
              const double w = pr.weights[i] * (x1 - x0) * agm_ * kInv2Pi * ch /
                               std::sqrt(sh * sh + (1.0 - tau2) * (1.0 - tau2));
              // φ = kπ/2 + δ for k ≡ 1 (π/2) or 3 (3π/2) mod 4.
              if (km == 1) node(-sd, cd, w);
              else node(sd, -cd, w);
            }
          }
        } else {
          for (size_t i = 0; i < rule.nodes.size(); ++i) {
            const double phi = a + (b - a) * rule.nodes[i];
            const double c = std::cos(phi), s = std::sin(phi);
            node(c, s, rule.weights[i] * (b - a) * kInv2Pi * factor_of_angle(c, s));
          }
        }
      }
      a = b;
      ++k;
    }
  }

 private:
  double p_;
  double agm_ = 1.0;
  double s_edge_ = 0.0;  // s at the edge of a peak panel, δ = π/4
  std::array<double, 24> ratio_{};
  int levels_ = 0;
};

// ---------------------------------------------------------------------------------------------------------------
// sin²φ of a direction; the normal itself has no azimuth and reads 0 (every azimuth agrees there).
double sin2_phi(const Vec3& w) {
  const double rho2 = w.x * w.x + w.y * w.y;
  return rho2 > 0 ? w.y * w.y / rho2 : 0.0;
}

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
  double lookup(const Vec3& w) const {
    return lookup_xs(x_of_mu(w.z), n_s_ == 1 ? 0.0 : std::sqrt(sin2_phi(w)));
  }

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
  // exactly: Gauss in every cell, in x and in φ (the interpolant is a cubic in x and in s = sin φ there; μ(x) and
  // sin φ are smooth).
  double cosine_average() const {
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

void check_layer(const SchlickLayer& l, const char* prefix) {
  auto bad = [&](const char* field, double v) {
    return std::string(prefix) + field + ": must be in [0, 1], got " + bake::format_number(v);
  };
  for (int i = 0; i < 3; ++i) {
    if (!(l.c[i] >= 0.0 && l.c[i] <= 1.0)) throw std::invalid_argument(bad("c", l.c[i]));
  }
  if (!(l.r >= 0.0 && l.r <= 1.0)) throw std::invalid_argument(bad("r", l.r));
  if (!(l.p >= 0.0 && l.p <= 1.0)) throw std::invalid_argument(bad("p", l.p));
}

std::string describe_layer(const SchlickLayer& l) {
  return "c=" + bake::format_rgb(l.c) + ", r=" + bake::format_number(l.r) + ", p=" + bake::format_number(l.p);
}

// Unit half vector of two directions of the upper hemisphere. Scaled first, so that directions nearly opposite
// along the horizon (|wo + wi| as small as 1e-200) do not underflow to a zero vector.
Vec3 half_vector(const Vec3& wo, const Vec3& wi) {
  Vec3 h = wo + wi;  // h.z > 0: both z are > 0
  const double m = std::max({std::fabs(h.x), std::fabs(h.y), h.z});
  h = h / m;
  return h / length(h);
}

// ---------------------------------------------------------------------------------------------------------------
// What a layer tabulates. It depends on (r, p) only, not on C.
struct LayerTables {
  DirectionTable e;   // E = albedo of f_ss
  DirectionTable e5;  // (1 − u)^5-weighted albedo of f_ss + f_ms (the double layer's transmission)
  double e_avg = 0;     // Ē = (1/π) ∫ E cos θ dω
  double ms_scale = 0;  // 1 / (π (1 − Ē))
};

// Models with the same (r, p) share their tables: a bake builds a model per material, and anisotropic tables take
// ~10–20 ms to build (isotropic ones under 1 ms). Bounded; the oldest entries go first. Two threads asking for the
// same new entry may both build it; either copy is kept.
std::shared_ptr<const LayerTables> cached_tables(double r, double p, const std::function<LayerTables()>& build) {
  constexpr size_t kCapacity = 256;
  static std::mutex mutex;
  static std::map<std::pair<double, double>, std::shared_ptr<const LayerTables>> cache;
  static std::deque<std::pair<double, double>> order;
  const auto key = std::make_pair(r, p);
  {
    const std::lock_guard<std::mutex> lock(mutex);
    if (auto it = cache.find(key); it != cache.end()) return it->second;
  }
  auto built = std::make_shared<const LayerTables>(build());
  const std::lock_guard<std::mutex> lock(mutex);
  const auto [it, inserted] = cache.emplace(key, std::move(built));
  if (inserted) {
    order.push_back(key);
    if (order.size() > kCapacity) {
      cache.erase(order.front());
      order.pop_front();
    }
  }
  return it->second;
}

// ---------------------------------------------------------------------------------------------------------------
// One layer: everything but S(u) is white; tables are built (or found in the cache) at construction.
class SchlickLayerModel {
 public:
  explicit SchlickLayerModel(const SchlickLayer& layer)
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

  const SchlickLayer& layer() const { return layer_; }

  // G(w) / v for a direction w with v = n·w and q = sin²φ_w, finite at grazing angles. k grows with the roughness
  // projected on the plane of incidence: α_w² = 2 r (c_x cos²φ_w + (1 − c_x) sin²φ_w), c_x = mean of cos²φ_h.
  double g_over_v(double v, double q) const {
    const double k = masking_k(q);
    return 1.0 / (k + (1.0 - k) * v);
  }
  double g_over_v(const Vec3& w) const { return g_over_v(w.z, sin2_phi(w)); }
  double masking_k(double q) const {
    if (azimuth_.isotropic()) return k_;
    const double a = alpha_ * std::sqrt(2.0 * (cx_ * (1.0 - q) + (1.0 - cx_) * q));
    return 0.5 * a * (1.0 + a);
  }
  // Z(t) with 1 + r t² − t² written as sin²θ_h + r t², exact for h at the normal.
  double Z(const Vec3& h) const {
    const double d = h.x * h.x + h.y * h.y + r_ * h.z * h.z;
    return r_ / (d * d);
  }

  // The white BRDF (S excluded) and u = wo·h, for a valid pair.
  double white(const Vec3& wo, const Vec3& wi, double* u_out) const {
    const Vec3 h = half_vector(wo, wi);
    const double u = std::clamp(dot(wo, h), 0.0, 1.0);
    *u_out = u;
    const double ss = g_over_v(wi) * g_over_v(wo) * Z(h) * azimuth_.factor(h.x, h.y) * kInv4Pi;
    const double ms = tables_->ms_scale * (1.0 - tables_->e.lookup(wo)) * (1.0 - tables_->e.lookup(wi));
    return ss + ms;
  }

  Rgb eval(const Vec3& wo, const Vec3& wi) const {
    if (!valid_reflection_pair(wo, wi)) return Rgb{};
    double u;
    const double f = white(wo, wi, &u);
    return fresnel_schlick(u, layer_.c) * f;
  }

  // Probability of sampling the microfacet lobe at wo.
  double lobe_probability(const Vec3& wo) const { return std::clamp(tables_->e.lookup(wo), 0.0, 1.0); }

  double pdf(const Vec3& wo, const Vec3& wi) const {
    if (!valid_reflection_pair(wo, wi)) return 0.0;
    const double ps = lobe_probability(wo);
    const Vec3 h = half_vector(wo, wi);
    const double u = dot(wo, h);
    // D(h) t / (4 u): the density of h, times the Jacobian of the reflection. u > 0 for two upper directions.
    const double spec = u > 0 ? Z(h) * azimuth_.factor(h.x, h.y) * h.z / (4.0 * kPi * u) : 0.0;
    return ps * spec + (1.0 - ps) * cosine_hemisphere_pdf(wi.z);
  }

  // wi by the model's mixture; below the horizon when the reflection falls there (the sample then fails).
  Vec3 sample_direction(const Vec3& wo, Point2 u, double uc) const {
    if (uc < lobe_probability(wo)) return reflect(wo, sample_normal(u));
    return sample_cosine_hemisphere(u);
  }

  // A normal with density D(h) t: tan²θ_h = r ξ / (1 − ξ) (GGX with α² = r), φ_h exactly from A_n.
  Vec3 sample_normal(Point2 u) const {
    const double xi = u.x;
    const double denom = (1.0 - xi) + r_ * xi;
    const double t = std::sqrt((1.0 - xi) / denom), st = std::sqrt(r_ * xi / denom);
    double c, s;
    azimuth_.sample(u.y, &c, &s);
    return {st * c, st * s, t};
  }

  // Albedo of the whole white layer weighted by Schlick's (1 − u)^5, for the double layer.
  double e5(const Vec3& w) const { return tables_->e5.lookup(w); }

 private:
  // ∫ f_ss cos θi dωi for the direction wo (and the same weighted by (1 − u)^5, for E5), integrated over the
  // normals h with density D(h) t: with ξ the CDF of θ_h and the azimuth weight folded into the nodes,
  // f_ss cos θi dωi = G(v) G(v') u / (v' t) × d(probability of h)  (dωi = 4u dω_h).
  // Reflections below the horizon (v ≤ 0) carry nothing. For θ_h ≤ (π/2 − θo)/2 every azimuth reflects above the
  // horizon; for θ_h ≥ (π/2 + θo)/2 none does; between them the azimuths with cos(φ_h − φo) > c* =
  // v'(1 − 2t²) / (2 t sin θo sin θ_h) do. Integrating each piece separately keeps every integrand smooth (the horizon
  // is a kink otherwise).
  struct AlbedoPair {
    double e = 0, e5 = 0;
  };
  AlbedoPair single_scattering_albedo(double mu, double phi_o) const {
    const double so = std::sqrt((1.0 - mu) * (1.0 + mu));
    const Vec3 wo{so * std::cos(phi_o), so * std::sin(phi_o), mu};
    const double gv_o = g_over_v(mu, std::sin(phi_o) * std::sin(phi_o));
    const QuadratureRule& rule = unit_rule(kThetaNodes);
    AlbedoPair sum;
    // η = 1 − ξ, the probability of normals steeper than θ_h: η(θ) = r / (r + tan²θ), computed without cancellation.
    const double asin_mu = std::asin(mu);
    const double th1 = 0.5 * asin_mu, th2 = kPiOver2 - 0.5 * asin_mu;
    const double tan1 = std::tan(th1), tan2 = std::tan(th2);
    const double eta_a = r_ / (r_ + tan1 * tan1), eta_b = r_ / (r_ + tan2 * tan2);

    auto at_normal_angle = [&](double eta, double weight, bool partial) {
      const double denom = eta + r_ * (1.0 - eta);
      const double t = std::sqrt(eta / denom), st = std::sqrt(r_ * (1.0 - eta) / denom);
      auto node = [&](double c, double s, double w) {
        const Vec3 h{st * c, st * s, t};
        const double u = dot(wo, h);
        const double v = 2.0 * u * t - mu;
        if (!(v > 0)) return;
        const Vec3 wi = h * (2.0 * u) - wo;
        const double g = v * g_over_v(v, sin2_phi(wi)) * u * gv_o / t * w * weight;
        sum.e += g;
        sum.e5 += g * pow5(1.0 - u);
      };
      if (!partial) {
        for (const auto& n : circle_nodes_) node(n[0], n[1], n[2]);
      } else {
        const double c_star = mu * (1.0 - 2.0 * t * t) / (2.0 * t * so * st);
        const double dphi = std::acos(std::clamp(c_star, -1.0, 1.0));
        if (azimuth_.isotropic()) {
          // φo = 0 and the integrand is even in φ_h: half the interval, twice the weight.
          azimuth_.integrate(0.0, dphi, [&](double c, double s, double w) { node(c, s, 2.0 * w); });
        } else {
          azimuth_.integrate(phi_o - dphi, phi_o + dphi, node);
        }
      }
    };
    // Region I: η ∈ [η_a, 1], every azimuth. Near η_a the reflections at φ_h − φo = π graze the horizon and G(v)
    // ramps up over v ~ k, i.e. over η − η_a ~ k η_a: the variable s = ln(η − η_a + k η_a) resolves that ramp and
    // still spreads nodes over the lobe (uniform in η).
    {
      const double eps = k_ * eta_a;
      const double s0 = std::log(eps), s1 = std::log(1.0 - eta_a + eps);
      for (size_t i = 0; i < rule.nodes.size(); ++i) {
        const double s = s0 + (s1 - s0) * rule.nodes[i], e = std::exp(s);
        at_normal_angle(std::min(1.0, eta_a + e - eps), rule.weights[i] * (s1 - s0) * e, false);
      }
    }
    // Region II: η ∈ [η_b, η_a], in ln η, which spreads the normals' angles evenly (η ≈ r cot²θ_h away from the
    // lobe). The integral over the shrinking azimuth interval behaves like (distance)^(3/2) at both ends, and G ramps
    // there too; the smoothstep substitution ln η = l_0 + (l_1 − l_0)(3τ² − 2τ³) makes that smooth for Gauss.
    // η_b → 0 at grazing wo: below ln η_a − 32 the normals carry at most e^(−32) of the probability and g ≤ 2/k²,
    // under 1e-5 even at kMinRoughness, so the range is cut there.
    // When A_n has peaks (at φ_h = ±π/2), the ends of the azimuth interval, where g vanishes, cross them at the θ_h
    // with c* = ±sin φo, i.e. cot 2θ_h = ∓ sin φo tan θo: a kink rounded over ~p. The range is cut there too.
    if (eta_a > eta_b && so > 0) {
      const double la = std::log(eta_a), lb = std::max(std::log(eta_b), la - 32.0);
      double breaks[4] = {lb, lb, lb, la};
      if (azimuth_.peaked()) {
        const double spread = std::atan2(std::fabs(std::sin(phi_o)) * so, mu);  // atan(sin φo tan θo) ∈ [0, θo]
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
            at_normal_angle(eta, pr.weights[i] * (l1 - l0) * ds * eta, true);
          }
        }
      }
    }
    return sum;
  }

  LayerTables build_tables() const {
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
  static void add_diffuse_e5(LayerTables& t) {
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

  SchlickLayer layer_;
  double r_, alpha_, k_;
  Azimuth azimuth_;
  std::vector<std::array<double, 3>> circle_nodes_;  // (cos φ, sin φ, weight) over the whole turn
  double cx_ = 0.5;  // mean of cos²φ_h under A_n (1/2 when isotropic)
  std::shared_ptr<const LayerTables> tables_;
};

}  // namespace

// ---------------------------------------------------------------------------------------------------------------
struct SchlickSingle::Impl {
  explicit Impl(const SchlickLayer& l) : model(l) {}
  SchlickLayerModel model;
};

SchlickSingle::SchlickSingle(const SchlickLayer& layer) {
  check_layer(layer, "");
  impl_ = std::make_unique<Impl>(layer);
}
SchlickSingle::~SchlickSingle() = default;

Rgb SchlickSingle::eval(const Vec3& wo, const Vec3& wi) const { return impl_->model.eval(wo, wi); }

std::optional<BsdfSample> SchlickSingle::sample(const Vec3& wo, Point2 u, double uc) const {
  if (!above_horizon(wo)) return std::nullopt;
  const Vec3 wi = impl_->model.sample_direction(wo, u, uc);
  return make_sample(wi, eval(wo, wi), pdf(wo, wi));  // fails below the horizon
}

double SchlickSingle::pdf(const Vec3& wo, const Vec3& wi) const { return impl_->model.pdf(wo, wi); }

std::string SchlickSingle::describe() const { return "schlick(" + describe_layer(impl_->model.layer()) + ")"; }

// ---------------------------------------------------------------------------------------------------------------
struct SchlickDouble::Impl {
  Impl(const SchlickLayer& t, const SchlickLayer& b) : top(t), bottom(b) {}
  SchlickLayerModel top, bottom;

  // T = 1 − E_top = 1 − (C + (1 − C) E5) = (1 − C)(1 − E5), per channel.
  Rgb transmission(const Vec3& w) const { return (Rgb(1.0) - top.layer().c) * (1.0 - top.e5(w)); }
  Rgb full_albedo(const SchlickLayerModel& m, const Vec3& w) const {
    return m.layer().c + (Rgb(1.0) - m.layer().c) * m.e5(w);
  }
  // Probability of sampling the top layer: its expected share of the reflected energy at wo.
  double top_probability(const Vec3& wo) const {
    const double wt = full_albedo(top, wo).average();
    const double wb = (transmission(wo) * full_albedo(bottom, wo)).average();
    // Both zero only for a black top over a black bottom, where nothing is reflected: any split will do.
    return wt + wb > 0 ? wt / (wt + wb) : 0.5;
  }
};

SchlickDouble::SchlickDouble(const SchlickLayer& top, const SchlickLayer& bottom) {
  check_layer(top, "top.");
  check_layer(bottom, "bottom.");
  impl_ = std::make_unique<Impl>(top, bottom);
}
SchlickDouble::~SchlickDouble() = default;

Rgb SchlickDouble::eval(const Vec3& wo, const Vec3& wi) const {
  if (!valid_reflection_pair(wo, wi)) return Rgb{};
  return impl_->top.eval(wo, wi) + impl_->transmission(wo) * impl_->transmission(wi) * impl_->bottom.eval(wo, wi);
}

std::optional<BsdfSample> SchlickDouble::sample(const Vec3& wo, Point2 u, double uc) const {
  if (!above_horizon(wo)) return std::nullopt;
  const double pt = impl_->top_probability(wo);
  // Reuse uc for the lobe choice inside the chosen layer, rescaled to [0, 1).
  Vec3 wi;
  if (uc < pt) {
    wi = impl_->top.sample_direction(wo, u, uc / pt);
  } else {
    wi = impl_->bottom.sample_direction(wo, u, (uc - pt) / (1.0 - pt));
  }
  return make_sample(wi, eval(wo, wi), pdf(wo, wi));  // fails below the horizon
}

double SchlickDouble::pdf(const Vec3& wo, const Vec3& wi) const {
  if (!valid_reflection_pair(wo, wi)) return 0.0;
  const double pt = impl_->top_probability(wo);
  return pt * impl_->top.pdf(wo, wi) + (1.0 - pt) * impl_->bottom.pdf(wo, wi);
}

std::string SchlickDouble::describe() const {
  return "schlick-double(top: " + describe_layer(impl_->top.layer()) +
         "; bottom: " + describe_layer(impl_->bottom.layer()) + ")";
}

}  // namespace kiln::brdf
