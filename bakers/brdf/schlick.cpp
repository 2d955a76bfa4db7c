// Schlick 1994, "An Inexpensive BRDF Model for Physically-based Rendering", in an energy-conserving form.
//
// Single layer (C, r, p), local frame with the normal along +z; t = n·h, u = wo·h, v = n·wi, v' = n·wo,
// w = cos of the azimuth of h from the tangent x:
//
//   f(wo, wi) = S(u) [f_ss + f_ms]
//   S(u)  = C + (1 − C)(1 − u)^5                                  (survey eq 18)
//   f_ss  = G(v) G(v') Z(t) A_n(w) / (4π v v') / (N(wo) N(wi))    (Schlick's microfacet term, single scattering)
//   f_ms  = (1 − E(wo)) (1 − E(wi)) / (π (1 − Ē))                 (energy masking removed, given back diffusely)
//   Z(t)  = r / (1 + r t² − t²)²                                  (eq 24; Z/π is GGX with α² = r, ∫ Z t dω_h = π)
//   A_n(w) = A(w) AGM(1, p) / sqrt(p),  A(w) = sqrt(p / (p² − p² w² + w²))   (eq 24, normalised)
//   G(v)  = v / (k − k v + v),  k = α (1 + α) / 2,  α = sqrt(r)
//   E(wo) = ∫ f_ss cos θi dωi (tabulated over μ = cos θo, and over the azimuth of wo when p < 1), Ē = (1/π)∫ E cos dω.
//
// Where and why this departs from the survey's printed eq 22–24 (see also SEED-NOTES.md):
// - Eq 23's second term (1 − G G') / (4π v v') is replaced by f_ms (Kelemen & Szirmay-Kalos 2001, Kulla & Conty
//   2017). As printed its albedo grows like 1/(2 v') at grazing angles and r = 1 is not Lambertian. With f_ms the
//   albedo of f_ss + f_ms is exactly E(wo) + (1 − E(wo)) = 1, so with C = 1 nothing is lost or created, and every
//   C ≤ 1 gives albedo ≤ 1 (S ≤ 1). At r = 1 (k = 1, G(v) = v, Z = 1) and p = 1: f_ss = 1/(4π), E = 1/4,
//   f_ms = 3/(4π), so f = 1/π: Lambertian.
// - Masking constant k. Schlick's paper uses k = r in G. With Z's width α = sqrt(r) that masks far too little: E
//   reaches 8 at v' = 0.001 for r = 0.001 and exceeds 1 for r ≲ 0.1 at grazing angles (measured with a brute-force
//   quadrature), which would make 1 − E and f_ms negative. Schlick's own derivation of G (survey eq 19) scales k
//   with the slope, i.e. with sqrt(r); k = α/2 is the usual fit of Smith's G1 for GGX (Karis 2013), and the factor
//   (1 + α) brings k to 1 at r = 1 so that r = 1 stays Lambertian. With it E ≤ 1 for p = 1 (tested).
// - A(w) averages sqrt(p) / AGM(1, p) over the azimuth, not 1 (complete elliptic integral of the first kind), so it
//   is divided by that mean: then D(h) = Z(t) A_n(w) / π is a normalised distribution of normals for every p.
// - N(w) = max(1, E_1(w)), where E_1 is the albedo of f_ss without N. For p < 1 the normals crowd into the plane
//   perpendicular to the tangent and masking with an isotropic k is too weak for views in that plane: E_1 reaches
//   about 1.1 at grazing angles for small r and p. Dividing by N(wo) N(wi) (symmetric, so still reciprocal) brings
//   the albedo back to ≤ 1 and changes nothing where E_1 ≤ 1 (always for p = 1).
// - r = 0 (a perfect mirror: a Dirac delta that no function holds) is represented by kMinRoughness, p = 0 (a delta in
//   the azimuth of h) by kMinIsotropy: the narrowest lobes whose tables stay accurate. describe() reports the values
//   asked for.
//
// Double layer: f = f_top + T(wo) T(wi) f_bottom, T = 1 − E_top per channel, with E_top(w) = C + (1 − C) E5(w) the
// full albedo of the top layer (E5 = ∫ (1 − u)^5 (f_ss + f_ms) cos θi dωi; the C part integrates to 1). Light reaches
// the bottom through the top and leaves through it again; the light the top's underside reflects back down
// (internal reflections between the layers) is neglected, so some energy is lost (measured in schlick_test). This
// replaces the survey's eq 25, S D + (1 − S(u)) S' D', whose weight 1 − S(u) is the transmission at one angle only
// and does not bound the albedo by 1. Here the albedo is ≤ A_top + T(wo) ≤ 1, and the sum is reciprocal.
//
// Sampling: single layer, with probability E(wo) the microfacet term (θ_h from GGX with α = sqrt(r), φ_h exactly from
// A_n by inverting its CDF, an incomplete elliptic integral, with the Jacobi amplitude; wi = reflect(wo, h)),
// otherwise a cosine-weighted direction; the pdf is the mixture. Double layer: top or bottom with probability
// proportional to their expected contributions at wo.
#include "bakers/brdf/schlick.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "bakers/brdf/describe.h"
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

// Resolution of the tables and of the quadrature that fills them (errors measured in schlick_test).
constexpr int kMuNodes = 40;        // table nodes over μ ∈ [0, 1]
constexpr double kGrazingScale = 1.0 / 6.0;  // the μ grid is ~kGrazingScale·k fine at grazing (E bends there)
constexpr int kPhiNodes = 9;        // table nodes over the folded azimuth of wo, [0, π/2] (p < 1 only)
constexpr int kThetaNodes = 16;     // Gauss nodes in θ_h per region (all azimuths visible / part of them)
constexpr int kAzimuthNodes = 8;    // Gauss nodes per azimuth panel (a quarter turn at most)
constexpr int kSphereMuNodes = 16;  // Gauss nodes over the μ of wi for the diffuse part of E5
constexpr int kSpherePhiNodes = 16; // midpoint nodes over the azimuth of wi for the same

const QuadratureRule& unit_rule(int n) {
  // Gauss–Legendre rules on [0, 1], built once (the constructor of a model must stay cheap).
  static const QuadratureRule r_theta = gauss_legendre(kThetaNodes, 0.0, 1.0);
  static const QuadratureRule r_azimuth = gauss_legendre(kAzimuthNodes, 0.0, 1.0);
  static const QuadratureRule r_sphere = gauss_legendre(kSphereMuNodes, 0.0, 1.0);
  static const QuadratureRule r4 = gauss_legendre(4, 0.0, 1.0);
  if (n == kThetaNodes) return r_theta;
  if (n == kAzimuthNodes) return r_azimuth;
  if (n == kSphereMuNodes) return r_sphere;
  return r4;
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
    if (p_ < kPeakedIsotropy) beta_ = p_ / std::sqrt((1.0 - p_) * (1.0 + p_));
  }

  double p() const { return p_; }
  double agm() const { return agm_; }
  bool isotropic() const { return p_ == 1.0; }

  // A_n for a half vector with tangent-plane components (hx, hy).
  double factor(double hx, double hy) const {
    if (isotropic()) return 1.0;
    const double rho2 = hx * hx + hy * hy;
    // h along the normal: w is undefined (the limit depends on the direction of approach); this single direction
    // has measure zero, and the azimuthal mean 1 keeps D continuous in the mean.
    if (!(rho2 > 0)) return 1.0;
    return agm_ * std::sqrt(rho2 / (hx * hx + p_ * p_ * hy * hy));
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
  // quarter-turn panels centred on kπ/2. Panels centred on a peak (k odd) use s with sin δ = β sinh s
  // (δ = φ − kπ/2, β = p / sqrt(1 − p²)), in which A_n dφ = AGM ds / (sqrt(1 − p²) cos δ): flat, whatever p.
  template <class Node>
  void integrate(double lo, double hi, Node&& node) const {
    const QuadratureRule& rule = unit_rule(kAzimuthNodes);
    const double quarter = kPiOver2;
    int k = static_cast<int>(std::floor((lo - kPiOver4) / quarter)) + 1;  // panel [π/4 + (k−1)π/2, π/4 + kπ/2]
    double a = lo;
    while (a < hi) {
      const double b = std::min(hi, kPiOver4 + k * quarter);
      const double centre = k * quarter;
      const int km = ((k % 4) + 4) % 4;
      const double d0 = a - centre, d1 = b - centre;
      if (b > a) {
        if ((km & 1) && beta_ > 0) {
          const double s0 = std::asinh(std::sin(d0) / beta_), s1 = std::asinh(std::sin(d1) / beta_);
          const double scale = agm_ / std::sqrt((1.0 - p_) * (1.0 + p_)) * kInv2Pi * (s1 - s0);
          for (size_t i = 0; i < rule.nodes.size(); ++i) {
            const double sd = std::clamp(beta_ * std::sinh(s0 + (s1 - s0) * rule.nodes[i]), -1.0, 1.0);
            const double cd = std::sqrt((1.0 - sd) * (1.0 + sd));
            const double w = rule.weights[i] * scale / cd;
            // φ = kπ/2 + δ for k ≡ 1 (π/2) or 3 (3π/2) mod 4.
            if (km == 1) node(-sd, cd, w);
            else node(sd, -cd, w);
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
  double beta_ = 0.0;  // p / sqrt(1 − p²) when the peaks need the flattening variable
  std::array<double, 24> ratio_{};
  int levels_ = 0;
};

// ---------------------------------------------------------------------------------------------------------------
// A function of wo over μ = cos θo ∈ [0, 1] and, when the model is anisotropic, the folded azimuth φ ∈ [0, π/2]
// (every term of the model depends on the azimuths only through cos² and sin², so E(φ) = E(−φ) = E(π − φ)).
// μ nodes sit at μ(x) = (e^(λx) − 1) / (e^λ − 1) for x uniform on [0, 1], with λ set so that the grid is about
// k fine near grazing, where the masking makes E change on the scale k. Catmull–Rom interpolation in x and φ,
// clamped to [0, 1].
class DirectionTable {
 public:
  DirectionTable() = default;
  DirectionTable(int n_mu, int n_phi, double grazing_scale)
      : n_mu_(n_mu), n_phi_(n_phi), lambda_(std::log1p(1.0 / grazing_scale)), values_(n_mu * n_phi, 0.0) {
    expm1_lambda_ = std::expm1(lambda_);
  }

  int n_mu() const { return n_mu_; }
  int n_phi() const { return n_phi_; }
  double mu_node(int j) const { return mu_of_x(static_cast<double>(j) / (n_mu_ - 1)); }
  double phi_node(int l) const { return n_phi_ == 1 ? 0.0 : kPiOver2 * l / (n_phi_ - 1); }
  double& at(int j, int l) { return values_[l * n_mu_ + j]; }
  double at(int j, int l) const { return values_[l * n_mu_ + j]; }
  double max() const { return *std::max_element(values_.begin(), values_.end()); }

  double mu_of_x(double x) const { return std::expm1(lambda_ * x) / expm1_lambda_; }
  double dmu_dx(double x) const { return lambda_ * std::exp(lambda_ * x) / expm1_lambda_; }

  // The value for a direction of the upper hemisphere (w.z > 0).
  double lookup(const Vec3& w) const {
    const double mu = std::min(1.0, w.z);
    const double x = std::log1p(mu * expm1_lambda_) / lambda_;
    // The normal itself has no azimuth; φ = 0 then (all azimuths agree there).
    const double phi = n_phi_ == 1 ? 0.0 : std::atan2(std::fabs(w.y), std::fabs(w.x));
    return lookup_xphi(x, phi);
  }

  double lookup_xphi(double x, double phi) const {
    const double fx = std::clamp(x, 0.0, 1.0) * (n_mu_ - 1);
    const int jx = std::min(n_mu_ - 2, static_cast<int>(fx));
    const double tx = fx - jx;
    if (n_phi_ == 1) return std::clamp(cubic_x(jx, tx, 0), 0.0, 1.0);
    const double fp = std::clamp(phi / kPiOver2, 0.0, 1.0) * (n_phi_ - 1);
    const int jp = std::min(n_phi_ - 2, static_cast<int>(fp));
    const double tp = fp - jp;
    double col[4];
    for (int i = 0; i < 4; ++i) col[i] = cubic_x(jx, tx, reflect_phi(jp - 1 + i));
    return std::clamp(catmull_rom(col[0], col[1], col[2], col[3], tp), 0.0, 1.0);
  }

  // (1/π) ∫ value(w) cos θ dω over the hemisphere, of the interpolant itself (Gauss in every cell: the interpolant is
  // a cubic there and μ(x) smooth), so that quantities built on it balance exactly.
  double cosine_average() const {
    const QuadratureRule& g = unit_rule(4);
    double sum = 0;
    const int cells_phi = n_phi_ == 1 ? 1 : n_phi_ - 1;
    for (int cp = 0; cp < cells_phi; ++cp) {
      for (size_t ip = 0; ip < g.nodes.size(); ++ip) {
        const double phi = n_phi_ == 1 ? 0.0 : kPiOver2 * (cp + g.nodes[ip]) / (n_phi_ - 1);
        const double wphi = g.weights[ip] / cells_phi;  // fraction of the quarter turn
        for (int cx = 0; cx < n_mu_ - 1; ++cx) {
          for (size_t ix = 0; ix < g.nodes.size(); ++ix) {
            const double x = (cx + g.nodes[ix]) / (n_mu_ - 1);
            const double wx = g.weights[ix] / (n_mu_ - 1);
            sum += wphi * wx * lookup_xphi(x, phi) * mu_of_x(x) * dmu_dx(x);
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
  // Node index in φ with the mirror symmetries at 0 and π/2.
  int reflect_phi(int l) const {
    if (l < 0) return -l;
    if (l > n_phi_ - 1) return 2 * (n_phi_ - 1) - l;
    return l;
  }
  // Along x, beyond the ends: linear extrapolation from the last two nodes.
  double cubic_x(int jx, double tx, int l) const {
    const double v1 = at(jx, l), v2 = at(jx + 1, l);
    const double v0 = jx > 0 ? at(jx - 1, l) : 2.0 * v1 - v2;
    const double v3 = jx + 2 < n_mu_ ? at(jx + 2, l) : 2.0 * v2 - v1;
    return catmull_rom(v0, v1, v2, v3, tx);
  }

  int n_mu_ = 0, n_phi_ = 1;
  double lambda_ = 1.0, expm1_lambda_ = 1.0;
  std::vector<double> values_;
};

void check_layer(const SchlickLayer& l, const char* prefix) {
  auto bad = [&](const char* field, double v) {
    return std::string(prefix) + field + ": must be in [0, 1], got " + format_number(v);
  };
  for (int i = 0; i < 3; ++i) {
    if (!(l.c[i] >= 0.0 && l.c[i] <= 1.0)) throw std::invalid_argument(bad("c", l.c[i]));
  }
  if (!(l.r >= 0.0 && l.r <= 1.0)) throw std::invalid_argument(bad("r", l.r));
  if (!(l.p >= 0.0 && l.p <= 1.0)) throw std::invalid_argument(bad("p", l.p));
}

std::string describe_layer(const SchlickLayer& l) {
  return "c=" + format_rgb(l.c) + ", r=" + format_number(l.r) + ", p=" + format_number(l.p);
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
// One layer: everything but S(u) is white; tables are built at construction.
class SchlickLayerModel {
 public:
  explicit SchlickLayerModel(const SchlickLayer& layer, bool with_e5)
      : layer_(layer),
        r_(std::max(layer.r, kMinRoughness)),
        alpha_(std::sqrt(r_)),
        k_(0.5 * alpha_ * (1.0 + alpha_)),
        azimuth_(std::max(layer.p, kMinIsotropy)) {
    // The nodes over the whole turn do not depend on wo: computed once.
    azimuth_.integrate(-kPiOver4, 7.0 * kPiOver4, [this](double c, double s, double w) {
      circle_nodes_.push_back({c, s, w});
    });
    build_tables(with_e5);
  }

  const SchlickLayer& layer() const { return layer_; }

  // G(v) / v, finite at grazing angles.
  double g_over_v(double v) const { return 1.0 / (k_ + (1.0 - k_) * v); }
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
    const double ss = g_over_v(wi.z) * g_over_v(wo.z) * Z(h) * azimuth_.factor(h.x, h.y) * kInv4Pi /
                      (renorm(wo) * renorm(wi));
    const double ms = ms_scale_ * (1.0 - e_.lookup(wo)) * (1.0 - e_.lookup(wi));
    return ss + ms;
  }

  Rgb eval(const Vec3& wo, const Vec3& wi) const {
    if (!valid_reflection_pair(wo, wi)) return Rgb{};
    double u;
    const double f = white(wo, wi, &u);
    return fresnel_schlick(u, layer_.c) * f;
  }

  // Probability of sampling the microfacet lobe at wo.
  double lobe_probability(const Vec3& wo) const { return std::clamp(e_.lookup(wo), 0.0, 1.0); }

  double pdf(const Vec3& wo, const Vec3& wi) const {
    if (!valid_reflection_pair(wo, wi)) return 0.0;
    const double ps = lobe_probability(wo);
    const Vec3 h = half_vector(wo, wi);
    const double u = dot(wo, h);
    // D(h) t / (4 u): the density of h, times the Jacobian of the reflection. u > 0 for two upper directions.
    const double spec = u > 0 ? Z(h) * azimuth_.factor(h.x, h.y) * h.z / (4.0 * kPi * u) : 0.0;
    return ps * spec + (1.0 - ps) * cosine_hemisphere_pdf(wi.z);
  }

  // wi by the model's mixture; nullopt-equivalent (z ≤ 0) when the reflection falls below the horizon.
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
  double e5(const Vec3& w) const { return e5_.lookup(w); }
  double albedo_ss(const Vec3& w) const { return e_.lookup(w); }
  double albedo_ss_cosine_average() const { return e_avg_; }
  double max_unnormalised_albedo() const { return e1_max_; }

 private:
  double renorm(const Vec3& w) const { return renormalised_ ? std::max(1.0, e1_.lookup(w)) : 1.0; }

  // ∫ f_ss cos θi dωi for the direction wo (and, when asked, the same weighted by (1 − u)^5), integrated over the
  // normals h with density D(h) t: with ξ the CDF of θ_h and the azimuth weight folded into the nodes,
  // f_ss cos θi dωi = G(v) G(v') u / (v' t) × d(probability of h)  (dωi = 4u dω_h).
  // Reflections below the horizon (v ≤ 0) carry nothing. For θ_h ≤ (π/2 − θo)/2 every azimuth reflects above the
  // horizon; for θ_h ≥ (π/2 + θo)/2 none does; between them the azimuths with cos(φ_h − φo) > c* =
  // v'(1 − 2t²) / (2 t sin θo sin θ_h) do. Integrating each piece separately keeps every integrand smooth (the horizon
  // is a kink otherwise).
  struct AlbedoPair {
    double e = 0, e5 = 0;
  };
  template <class Weight>
  AlbedoPair single_scattering_albedo(double mu, double phi_o, bool with_e5, Weight&& wi_weight) const {
    const double so = std::sqrt((1.0 - mu) * (1.0 + mu));
    const Vec3 wo{so * std::cos(phi_o), so * std::sin(phi_o), mu};
    const double gv_o = g_over_v(mu);
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
        const double g = v * g_over_v(v) * u * gv_o / t * wi_weight(wo, h, u, v) * w * weight;
        sum.e += g;
        if (with_e5) sum.e5 += g * pow5(1.0 - u);
      };
      if (!partial) {
        for (const auto& n : circle_nodes_) node(n[0], n[1], n[2]);
      } else {
        const double c_star = mu * (1.0 - 2.0 * t * t) / (2.0 * t * so * st);
        const double dphi = std::acos(std::clamp(c_star, -1.0, 1.0));
        azimuth_.integrate(phi_o - dphi, phi_o + dphi, node);
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
    // there too; the smoothstep substitution ln η = l_b + (l_a − l_b)(3τ² − 2τ³) makes that smooth for Gauss.
    // η_b → 0 at grazing wo: below ln η_a − 32 the normals carry at most e^(−32) of the probability and g ≤ 2/k²,
    // under 1e-5 even at kMinRoughness, so the range is cut there.
    if (eta_a > eta_b && so > 0) {
      const double la = std::log(eta_a), lb = std::max(std::log(eta_b), la - 32.0);
      for (size_t i = 0; i < rule.nodes.size(); ++i) {
        const double tau = rule.nodes[i];
        const double s = tau * tau * (3.0 - 2.0 * tau), ds = 6.0 * tau * (1.0 - tau);
        const double eta = std::exp(lb + (la - lb) * s);
        at_normal_angle(eta, rule.weights[i] * (la - lb) * ds * eta, true);
      }
    }
    return sum;
  }

  void build_tables(bool with_e5) {
    const int n_phi = azimuth_.isotropic() ? 1 : kPhiNodes;
    e1_ = DirectionTable(kMuNodes, n_phi, kGrazingScale * k_);
    auto one = [](const Vec3&, const Vec3&, double, double) { return 1.0; };
    for (int l = 0; l < n_phi; ++l) {
      for (int j = 0; j < kMuNodes; ++j) e1_.at(j, l) = single_scattering_albedo(e1_.mu_node(j), e1_.phi_node(l), false, one).e;
    }
    e1_max_ = e1_.max();
    // Where f_ss alone would reflect more than it receives, divide by N(wo) N(wi) (see the top of the file) and
    // integrate again with 1/N(wi) inside.
    renormalised_ = e1_max_ > 1.0;
    e_ = e1_;
    DirectionTable e5_ss(kMuNodes, n_phi, kGrazingScale * k_);
    if (renormalised_ || with_e5) {
      auto inv_n = [this](const Vec3& wo, const Vec3& h, double u, double v) {
        if (!renormalised_) return 1.0;
        const Vec3 wi = h * (2.0 * u) - wo;
        return 1.0 / (std::max(1.0, e1_.lookup(Vec3{wi.x, wi.y, v})) * std::max(1.0, e1_.lookup(wo)));
      };
      for (int l = 0; l < n_phi; ++l) {
        for (int j = 0; j < kMuNodes; ++j) {
          const AlbedoPair a = single_scattering_albedo(e_.mu_node(j), e_.phi_node(l), with_e5, inv_n);
          e_.at(j, l) = a.e;
          e5_ss.at(j, l) = a.e5;
        }
      }
    }
    e_avg_ = e_.cosine_average();
    // f_ms = (1 − E(wo)) (1 − E(wi)) / (π (1 − Ē)). 1 − Ē > 0 because E < 1 over most of the hemisphere (masking
    // is always > 0 away from the normal); if the tables ever said otherwise there is no energy left to return.
    ms_scale_ = e_avg_ < 1.0 ? kInvPi / (1.0 - e_avg_) : 0.0;
    if (with_e5) build_e5(e5_ss);
  }

  // E5(wo) = ∫ (1 − u)^5 (f_ss + f_ms) cos θi dωi: the single-scattering part came with E; the diffuse part is
  // smooth in wi and integrated on a (x(μi), φi) grid.
  void build_e5(const DirectionTable& e5_ss) {
    e5_ = e5_ss;
    const QuadratureRule& gx = unit_rule(kSphereMuNodes);
    for (int l = 0; l < e5_.n_phi(); ++l) {
      for (int j = 0; j < e5_.n_mu(); ++j) {
        const double mu = e5_.mu_node(j), phi_o = e5_.phi_node(l);
        const double so = std::sqrt((1.0 - mu) * (1.0 + mu));
        const Vec3 wo{so * std::cos(phi_o), so * std::sin(phi_o), mu};
        double sum = 0;
        for (size_t ix = 0; ix < gx.nodes.size(); ++ix) {
          const double x = gx.nodes[ix];
          const double mui = e_.mu_of_x(x), wmu = gx.weights[ix] * e_.dmu_dx(x) * mui;
          const double si = std::sqrt((1.0 - mui) * (1.0 + mui));
          for (int ip = 0; ip < kSpherePhiNodes; ++ip) {
            const double phi = 2.0 * kPi * (ip + 0.5) / kSpherePhiNodes;
            const double cp = std::cos(phi), sp = std::sin(phi);
            const Vec3 wi{si * cp, si * sp, mui};
            const double u = std::sqrt(std::max(0.0, 0.5 * (1.0 + dot(wo, wi))));
            const double ewi = e_.lookup_xphi(x, std::atan2(std::fabs(sp), std::fabs(cp)));
            sum += wmu * (2.0 * kPi / kSpherePhiNodes) * pow5(1.0 - u) * (1.0 - ewi);
          }
        }
        const double ewo = e_.lookup_xphi(static_cast<double>(j) / (e5_.n_mu() - 1), phi_o);
        e5_.at(j, l) += ms_scale_ * (1.0 - ewo) * sum;
      }
    }
  }

  SchlickLayer layer_;
  double r_, alpha_, k_;
  Azimuth azimuth_;
  std::vector<std::array<double, 3>> circle_nodes_;  // (cos φ, sin φ, weight) over the whole turn
  DirectionTable e1_;   // albedo of f_ss without N
  DirectionTable e_;    // albedo of f_ss (with N): E
  DirectionTable e5_;   // (1 − u)^5-weighted albedo of f_ss + f_ms (double layer only)
  double e1_max_ = 0;
  bool renormalised_ = false;
  double e_avg_ = 0;
  double ms_scale_ = 0;
};

}  // namespace

// ---------------------------------------------------------------------------------------------------------------
struct SchlickSingle::Impl {
  explicit Impl(const SchlickLayer& l) : model(l, false) {}
  SchlickLayerModel model;
};

SchlickSingle::SchlickSingle(const SchlickLayer& layer) {
  check_layer(layer, "");
  impl_ = std::make_unique<Impl>(layer);
}
SchlickSingle::~SchlickSingle() = default;

Rgb SchlickSingle::eval(const Vec3& wo, const Vec3& wi) const { return impl_->model.eval(wo, wi); }

std::optional<BsdfSample> SchlickSingle::sample(const Vec3& wo, Point2 u, double uc) const {
  if (!(wo.z > 0) || !is_finite(wo)) return std::nullopt;
  const Vec3 wi = impl_->model.sample_direction(wo, u, uc);
  if (!(wi.z > 0)) return std::nullopt;
  return make_sample(wi, eval(wo, wi), pdf(wo, wi));
}

double SchlickSingle::pdf(const Vec3& wo, const Vec3& wi) const { return impl_->model.pdf(wo, wi); }

std::string SchlickSingle::describe() const { return "schlick(" + describe_layer(impl_->model.layer()) + ")"; }

// ---------------------------------------------------------------------------------------------------------------
struct SchlickDouble::Impl {
  Impl(const SchlickLayer& t, const SchlickLayer& b) : top(t, true), bottom(b, true) {}
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
  if (!(wo.z > 0) || !is_finite(wo)) return std::nullopt;
  const double pt = impl_->top_probability(wo);
  // Reuse uc for the lobe choice inside the chosen layer, rescaled to [0, 1).
  Vec3 wi;
  if (uc < pt) {
    wi = impl_->top.sample_direction(wo, u, uc / pt);
  } else {
    wi = impl_->bottom.sample_direction(wo, u, (uc - pt) / (1.0 - pt));
  }
  if (!(wi.z > 0)) return std::nullopt;
  return make_sample(wi, eval(wo, wi), pdf(wo, wi));
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
