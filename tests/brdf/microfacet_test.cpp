// Microfacet distributions and the microfacet BRDF against analytic results: normalisation of D, the weak white
// furnace test, Smith's Λ against its definition, sampling against its density, and the BRDF's closed forms.
//
// The references here are written out from the papers (Walter et al. 2007, Heitz 2014, Schlick 1994, Cook & Torrance
// 1982) in θ/φ form with trigonometry, independently of the library's component form, and integrals are computed by
// deterministic composite Gauss–Legendre quadrature whose convergence is checked by refinement in each test.
#include "bakers/brdf/microfacet.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <functional>
#include <vector>

#include "bakers/brdf/beckmann_visible.h"
#include "bakers/brdf/fresnel.h"
#include "bakers/brdf/microfacet_distribution.h"
#include "bakers/brdf/model_spec.h"
#include "bakers/math/constants.h"
#include "bakers/math/quadrature.h"
#include "bakers/math/rng.h"
#include "tests/support/tolerance.h"

namespace kiln::brdf {
namespace {

using test::close;

constexpr double kDeg = kPi / 180.0;

Vec3 spherical(double theta, double phi) {
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

// ---------------------------------------------------------------------------------------------------------------
// Independent references, from the papers, in spherical coordinates.

// tan²θ (cos²φ/α_x² + sin²φ/α_y²): the elliptical slope norm of both distributions (Heitz 2014, eq 84–85).
double slope_norm2(double theta, double phi, double ax, double ay) {
  const double t = std::tan(theta), c = std::cos(phi), s = std::sin(phi);
  return t * t * (c * c / (ax * ax) + s * s / (ay * ay));
}
double d_ggx_ref(double theta, double phi, double ax, double ay) {
  if (theta >= kPiOver2) return 0.0;
  const double c2 = std::cos(theta) * std::cos(theta);
  const double k = 1.0 + slope_norm2(theta, phi, ax, ay);
  return 1.0 / (kPi * ax * ay * c2 * c2 * k * k);
}
double d_beckmann_ref(double theta, double phi, double ax, double ay) {
  if (theta >= kPiOver2) return 0.0;
  const double c2 = std::cos(theta) * std::cos(theta);
  return std::exp(-slope_norm2(theta, phi, ax, ay)) / (kPi * ax * ay * c2 * c2);
}
// Schlick 1994 / survey eq 20 in t = cos θ_h, support [1 − m, 1], divided by π (eq 20 integrates to π).
double d_schlick_ref(double t, double m) {
  const double x = t + m - 1.0;
  if (x <= 0.0) return 0.0;
  const double q = m * x * x - x * x + m * m;
  return m * m * m * x / (t * q * q) / kPi;
}
// Projected roughness along the azimuth φ (Heitz 2014, eq 80).
double alpha_along(double phi, double ax, double ay) {
  return std::sqrt(std::cos(phi) * std::cos(phi) * ax * ax + std::sin(phi) * std::sin(phi) * ay * ay);
}
// Smith Λ closed forms (Walter et al. 2007, eq 27 and eq 34 / Heitz 2014, eq 86 and 72).
double lambda_ggx_ref(double theta, double alpha) {
  const double a2t2 = alpha * alpha * std::tan(theta) * std::tan(theta);
  return a2t2 / (1.0 + std::sqrt(1.0 + a2t2)) / 2.0;  // (−1 + sqrt(1 + x)) / 2 without the cancellation
}
double lambda_beckmann_ref(double theta, double alpha) {
  if (theta == 0.0) return 0.0;
  const double a = 1.0 / (alpha * std::tan(theta));
  return 0.5 * (-std::erfc(a)) + std::exp(-a * a) / (2.0 * a * std::sqrt(kPi));
}

// ---------------------------------------------------------------------------------------------------------------
// Quadrature over the hemisphere of microfacet normals h, in slope coordinates. The slope r = tan θ_h is mapped from
// u ∈ [0, 1) by r = s(φ) u / (1 − u), where s(φ) = (cos²φ/α_x² + sin²φ/α_y²)^{-1/2} is the lobe's width along φ.
// Whatever α is (0.01 or 1), the lobe sits around u ≈ 1/2, and the tail of GGX (∝ r⁻³ in D cos θ dω) becomes a
// smooth function of u that vanishes at u = 1, so a composite Gauss–Legendre rule in u converges fast.
// dω_h = r / (1 + r²)^{3/2} dr dφ. The azimuth is the eccentric angle ψ of the ellipse, φ = atan2(α_y sin ψ,
// α_x cos ψ): ∫ D cos θ dω over one radial line is ∝ s(φ)², which for α_y/α_x = 10 is a sharp peak in φ but
// constant in ψ (dφ/dψ = α_x α_y / (α_x² cos²ψ + α_y² sin²ψ) = α_x α_y / s(φ)²).
//
// `u_max(φ)` cuts the radial integral where the integrand has a kink or ends (o·h = 0 for the visible normals, the
// support of Schlick's D), so that each piece is smooth. `phi_breaks` split the azimuth where u_max is not smooth in
// φ (φ_o ± π/2, where the cut o·h = 0 leaves the hemisphere and r_cut → ∞); near them u_max changes on a scale
// ∝ cot θ_o / α, so the azimuth mesh is graded geometrically towards each break.
struct Resolution {
  int panels_u, panels_phi;
};
double integrate_hemisphere(const std::function<double(const Vec3&)>& f, double ax, double ay,
                            const std::function<double(double)>& u_max, const std::vector<double>& phi_breaks,
                            Resolution res) {
  constexpr int kOrder = 20;
  // One rule on [0, 1], scaled to every interval (computing the nodes is far dearer than using them).
  static const QuadratureRule base = gauss_legendre(kOrder, 0.0, 1.0);
  const auto composite = [&](int panels, double a, double b) {
    QuadratureRule out;
    const double h = (b - a) / panels;
    for (int p = 0; p < panels; ++p) {
      for (int k = 0; k < kOrder; ++k) {
        out.nodes.push_back(a + h * (p + base.nodes[k]));
        out.weights.push_back(h * base.weights[k]);
      }
    }
    return out;
  };
  // Eccentric angle of φ: continuous and increasing, ψ − φ is 2π-periodic.
  const auto psi_of = [&](double phi) {
    const double turns = std::floor(phi / (2 * kPi));
    const double p = phi - 2 * kPi * turns;
    double psi = std::atan2(ax * std::sin(p), ay * std::cos(p));
    if (psi < 0) psi += 2 * kPi;
    return psi + 2 * kPi * turns;
  };
  std::vector<double> breaks;
  for (double phi : phi_breaks) {
    const double b = std::fmod(psi_of(phi), 2 * kPi);
    breaks.push_back(b);
    for (double d : {2e-3, 1e-2, 5e-2, 0.25, 1.0}) {
      breaks.push_back(std::fmod(b + d, 2 * kPi));
      breaks.push_back(std::fmod(b - d + 2 * kPi, 2 * kPi));
    }
  }
  if (breaks.empty()) breaks = {0.0};
  std::sort(breaks.begin(), breaks.end());
  breaks.push_back(breaks.front() + 2.0 * kPi);
  double total = 0.0;
  for (size_t seg = 0; seg + 1 < breaks.size(); ++seg) {
    if (!(breaks[seg + 1] > breaks[seg])) continue;
    const QuadratureRule psi_rule = composite(res.panels_phi, breaks[seg], breaks[seg + 1]);
    for (size_t j = 0; j < psi_rule.nodes.size(); ++j) {
      const double psi = psi_rule.nodes[j];
      const double phi = std::atan2(ay * std::sin(psi), ax * std::cos(psi));
      const double cp = std::cos(phi), sp = std::sin(phi);
      const double s2 = 1.0 / (cp * cp / (ax * ax) + sp * sp / (ay * ay));
      const double s = std::sqrt(s2);
      const double dphi_dpsi = ax * ay / s2;
      const double um = u_max(phi);
      if (!(um > 0)) continue;
      const QuadratureRule u_rule = composite(res.panels_u, 0.0, um);
      double inner = 0.0;
      for (size_t i = 0; i < u_rule.nodes.size(); ++i) {
        const double u = u_rule.nodes[i];
        const double r = s * u / (1.0 - u);
        const double dr_du = s / ((1.0 - u) * (1.0 - u));
        const double c = 1.0 / std::sqrt(1.0 + r * r);  // cos θ_h
        const Vec3 h{r * c * cp, r * c * sp, c};
        inner += u_rule.weights[i] * f(h) * r * c * c * c * dr_du;
      }
      total += psi_rule.weights[j] * dphi_dpsi * inner;
    }
  }
  return total;
}

constexpr Resolution kCoarse{4, 1}, kFine{8, 2};

double no_cut(double) { return 1.0; }

// u at the great circle o·h = 0 for the azimuth φ of h: o·h ∝ o.z + r (o.x cos φ + o.y sin φ), so the facets beyond
// r = o.z / −(o.x cos φ + o.y sin φ) face away from o.
std::function<double(double)> visible_cut(const Vec3& o, double ax, double ay) {
  return [=](double phi) {
    const double cp = std::cos(phi), sp = std::sin(phi);
    const double c = o.x * cp + o.y * sp;
    if (c >= 0.0) return 1.0;
    const double s = 1.0 / std::sqrt(cp * cp / (ax * ax) + sp * sp / (ay * ay));
    const double r_cut = o.z / -c;
    return r_cut / (s + r_cut);
  };
}
std::vector<double> visible_breaks(const Vec3& o) {
  const double phi_o = std::atan2(o.y, o.x);
  return {phi_o - kPiOver2, phi_o + kPiOver2};
}

struct Lobe {
  const char* name;
  double ax, ay;
};
std::vector<Lobe> lobes() {
  std::vector<Lobe> out;
  for (double a : {0.01, 0.02, 0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0}) out.push_back({"isotropic", a, a});
  out.push_back({"anisotropic", 0.01, 0.1});
  out.push_back({"anisotropic", 0.05, 0.5});
  out.push_back({"anisotropic", 0.3, 0.05});
  out.push_back({"anisotropic", 1.0, 0.2});
  return out;
}
const char* name(Distribution d) {
  return d == Distribution::ggx ? "ggx" : d == Distribution::beckmann ? "beckmann" : "schlick-beckmann";
}

// ---------------------------------------------------------------------------------------------------------------

TEST(MicrofacetDistribution, MatchesThePublishedFormulasPointwise) {
  for (const Lobe& l : lobes()) {
    const MicrofacetDistribution ggx(Distribution::ggx, l.ax, l.ay), beck(Distribution::beckmann, l.ax, l.ay);
    for (double theta_deg = 0.0; theta_deg < 90.0; theta_deg += 0.5) {
      for (double phi = 0.1; phi < 2 * kPi; phi += 0.7) {
        const double theta = theta_deg * kDeg;
        const Vec3 h = spherical(theta, phi);
        // The references use tan and cos of θ, the library the Cartesian components: both are a few roundings of
        // well-conditioned expressions, except exp(−e) whose relative error is e·ε ≤ 700 ε ≈ 1.6e-13 → 1e-11.
        EXPECT_TRUE(close(ggx.D(h), d_ggx_ref(theta, phi, l.ax, l.ay), 1e-11, 1e-300)) << l.ax << " " << theta_deg;
        EXPECT_TRUE(close(beck.D(h), d_beckmann_ref(theta, phi, l.ax, l.ay), 1e-11, 1e-300))
            << l.ax << " " << l.ay << " " << theta_deg << " " << phi;
      }
    }
    // At the normal both are 1 / (π α_x α_y): the peak every closed form below relies on.
    EXPECT_TRUE(close(ggx.D({0, 0, 1}), 1.0 / (kPi * l.ax * l.ay), 1e-15));
    EXPECT_TRUE(close(beck.D({0, 0, 1}), 1.0 / (kPi * l.ax * l.ay), 1e-15));
    // χ⁺: nothing at or below the horizon.
    EXPECT_EQ(ggx.D({1, 0, 0}), 0.0);
    EXPECT_EQ(beck.D({0, 1, 0}), 0.0);
    EXPECT_EQ(ggx.D({0, 0.6, -0.8}), 0.0);
  }
  for (double m : {0.01, 0.1, 0.3, 0.7, 1.0}) {
    const MicrofacetDistribution sch(Distribution::schlick_beckmann, m, m);
    for (double theta_deg = 0.0; theta_deg < 90.0; theta_deg += 0.25) {
      const double t = std::cos(theta_deg * kDeg);
      EXPECT_TRUE(close(sch.D(spherical(theta_deg * kDeg, 1.0)), d_schlick_ref(t, m), 1e-13, 1e-300))
          << "m=" << m << " theta=" << theta_deg;
    }
    // Schlick's D at the normal equals Beckmann's peak 1/(π m²): x = m, q = m³, D = m⁴ / m⁶ / π.
    // x = t + m − 1 at t = 1 rounds to within ε of m, i.e. ε/m relative (2e-14 at m = 0.01), and D ∝ x/q² with
    // q ∝ x²: 1e-12 relative covers m ≥ 0.01.
    EXPECT_TRUE(close(sch.D({0, 0, 1}), 1.0 / (kPi * m * m), 1e-12)) << "m=" << m;
  }
}

// ∫ D(h) cos θ_h dω_h = 1 (Walter et al. 2007, eq 4): the projected area of the microsurface is the macrosurface's.
TEST(MicrofacetDistribution, ProjectedAreaIsNormalised) {
  double worst = 0.0;
  for (Distribution kind : {Distribution::ggx, Distribution::beckmann}) {
    for (const Lobe& l : lobes()) {
      const MicrofacetDistribution d(kind, l.ax, l.ay);
      const auto f = [&](const Vec3& h) { return d.D(h) * h.z; };
      const double coarse = integrate_hemisphere(f, l.ax, l.ay, no_cut, {}, kCoarse);
      const double fine = integrate_hemisphere(f, l.ax, l.ay, no_cut, {}, kFine);
      // Refinement: doubling both panel counts changes the result by less than 1e-12, so the fine value is
      // converged far below that (Gauss–Legendre of order 20 on smooth integrands converges geometrically).
      EXPECT_LT(std::fabs(fine - coarse), 1e-12) << name(kind) << " " << l.ax << "×" << l.ay;
      // What is left is the normalisation error of D itself; 1e-11 is well above rounding (~1e-14 over ~1e5 terms).
      EXPECT_NEAR(fine, 1.0, 1e-11) << name(kind) << " " << l.ax << "×" << l.ay;
      worst = std::fmax(worst, std::fabs(fine - 1.0));
    }
  }
  std::printf("GGX and Beckmann, alpha 0.01..1 (iso and aniso): max |∫D cos − 1| = %.2e\n", worst);
}

// Schlick's rational Beckmann, divided by π. Measured: it is normalised EXACTLY, not approximately. In t = cos θ_h and
// x = t + m − 1, 2π ∫ D t dt / π = 2 ∫₀^m m³ x dx / (m² − (1 − m) x²)², and with y = x² this is
// m³ / (1 − m) · [1/(m² − (1 − m) y)]₀^{m²} = m³/(1 − m) · (1/m³ − 1/m²) = 1 for every m ∈ (0, 1] (m = 1: D = 1/π).
TEST(MicrofacetDistribution, SchlickRationalBeckmannNormalisationMeasured) {
  std::printf("Schlick's rational Beckmann, ∫ D cos dω − 1 by quadrature:\n");
  double worst = 0.0;
  for (double m : {0.01, 0.02, 0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 0.9, 1.0}) {
    const MicrofacetDistribution d(Distribution::schlick_beckmann, m, m);
    // D = 0 for cos θ_h < 1 − m: integrate up to r = tan θ_max only, since D has a kink there.
    const double r_max = m < 1.0 ? std::sqrt(1.0 - (1.0 - m) * (1.0 - m)) / (1.0 - m) : INFINITY;
    const auto u_max = [&](double) { return std::isfinite(r_max) ? r_max / (m + r_max) : 1.0; };
    const auto f = [&](const Vec3& h) { return d.D(h) * h.z; };
    // The GGX-like tail (D ≈ m²/r⁴ out to r_max ≈ sqrt(2m)) needs twice the radial panels of kCoarse at m = 0.01.
    const double coarse = integrate_hemisphere(f, m, m, u_max, {}, Resolution{8, 1});
    const double fine = integrate_hemisphere(f, m, m, u_max, {}, Resolution{16, 2});
    // Floor: D is ill-conditioned in t = cos θ_h near the peak (q = m² − (1 − m)x² ≈ m³ while dq/dx ≈ 2m), so the
    // rounding of t alone (ε ≈ 1.1e-16) perturbs D by ≈ 4ε/m² relative: 4.4e-12 at m = 0.01. Both the refinement
    // difference and the deviation from 1 are asserted at 1e-11, just above that floor.
    EXPECT_LT(std::fabs(fine - coarse), 1e-11) << "m=" << m;
    std::printf("  m=%-5g  %+.2e\n", m, fine - 1.0);
    // The analytic deviation is 0; what is measured is quadrature and rounding.
    EXPECT_NEAR(fine, 1.0, 1e-11) << "m=" << m;
    worst = std::fmax(worst, std::fabs(fine - 1.0));
  }
  std::printf("  max |deviation| = %.2e (analytically exactly 0)\n", worst);
}

// Heitz 2014, eq 2 and §5: the distribution of visible normals integrates to 1 for every direction o, which is the
// statement that G1 = 1/(1 + Λ) is consistent with D ("weak white furnace test").
TEST(MicrofacetDistribution, WeakWhiteFurnace) {
  double worst = 0.0;
  for (Distribution kind : {Distribution::ggx, Distribution::beckmann}) {
    for (const Lobe& l : lobes()) {
      if (l.ax < 0.05 && l.ay < 0.05) continue;  // the brief's range is α ∈ [0.05, 1]; 0.01/0.02 are covered above
      const MicrofacetDistribution d(kind, l.ax, l.ay);
      for (double theta_deg : {0.0, 10.0, 30.0, 45.0, 60.0, 75.0, 85.0, 88.0, 89.0}) {
        for (double phi_o : {0.0, 0.9}) {
          if (l.ax == l.ay && phi_o != 0.0) continue;  // isotropic: the azimuth of o does not matter
          const Vec3 o = spherical(theta_deg * kDeg, phi_o);
          const auto f = [&](const Vec3& h) { return d.D_visible(o, h); };
          const double coarse =
              integrate_hemisphere(f, l.ax, l.ay, visible_cut(o, l.ax, l.ay), visible_breaks(o), kCoarse);
          const double fine = integrate_hemisphere(f, l.ax, l.ay, visible_cut(o, l.ax, l.ay), visible_breaks(o), kFine);
          // Converged by refinement to < 1e-11 (the cut at o·h = 0 keeps each piece smooth) ...
          EXPECT_LT(std::fabs(fine - coarse), 1e-11) << name(kind) << " " << l.ax << "×" << l.ay << " θo=" << theta_deg;
          // ... so a deviation above 1e-10 would be an inconsistency between D and Λ, not quadrature error.
          EXPECT_NEAR(fine, 1.0, 1e-10) << name(kind) << " " << l.ax << "×" << l.ay << " θo=" << theta_deg
                                        << " φo=" << phi_o;
          worst = std::fmax(worst, std::fabs(fine - 1.0));
        }
      }
    }
  }
  std::printf("weak white furnace, GGX and Beckmann, θo 0..89°, α 0.05..1: max |∫D_vis − 1| = %.2e\n", worst);
}

// Schlick's rational D is paired with the exact Beckmann Λ (the library has no Λ of its own for it). Its tail
// (∝ m²/tan⁴θ_h up to cos θ_h = 1 − m) is much heavier than Beckmann's, so the pair is not consistent: the visible
// normals integrate to more than 1 towards grazing, which is energy gain in a BRDF built on them. Measured here, and
// asserted as documented: exactly 1 at normal incidence (G1(n) = 1 and D is normalised), above 1 at grazing.
TEST(MicrofacetDistribution, SchlickRationalBeckmannWithBeckmannMaskingMeasured) {
  std::printf("Schlick's rational D with Beckmann's G1, ∫ D_visible dω_h − 1:\n");
  for (double m : {0.1, 0.5, 1.0}) {
    const MicrofacetDistribution d(Distribution::schlick_beckmann, m, m);
    const double r_max = m < 1.0 ? std::sqrt(1.0 - (1.0 - m) * (1.0 - m)) / (1.0 - m) : INFINITY;
    const double u_support = std::isfinite(r_max) ? r_max / (m + r_max) : 1.0;
    std::printf("  m=%-4g", m);
    for (double theta_deg : {0.0, 45.0, 70.0, 80.0, 89.0}) {
      const Vec3 o = spherical(theta_deg * kDeg, 0.0);
      const auto visible = visible_cut(o, m, m);
      const auto u_max = [&](double phi) { return std::fmin(u_support, visible(phi)); };
      const auto f = [&](const Vec3& h) { return d.D_visible(o, h); };
      const double coarse = integrate_hemisphere(f, m, m, u_max, visible_breaks(o), Resolution{8, 1});
      const double fine = integrate_hemisphere(f, m, m, u_max, visible_breaks(o), Resolution{16, 2});
      // Where the support cut and the visibility cut cross, u_max has a kink in φ that no break resolves: the
      // refinement difference shows the quadrature is still good to 1e-6, far below the effect measured.
      EXPECT_LT(std::fabs(fine - coarse), 1e-6) << "m=" << m << " θo=" << theta_deg;
      std::printf("  θo=%g°: %+.4f", theta_deg, fine - 1.0);
      if (theta_deg == 0.0) {
        EXPECT_NEAR(fine, 1.0, 1e-11) << "m=" << m;  // as in the normalisation test
      }
      if (theta_deg == 89.0) {
        EXPECT_GT(fine, 1.01) << "m=" << m;  // the documented energy gain at grazing
      }
    }
    std::printf("\n");
  }
}

// Λ from its definition in slope space (Heitz 2014, eq 72): with μ = cot θ_o and P2 the marginal density of the slope
// along the azimuth of o, Λ(o) = (1/μ) ∫_μ^∞ (q − μ) P2(q) dq. The marginals are written out here: Beckmann's is the
// Gaussian exp(−q²/α²)/(α sqrt(π)); GGX's is 1/(2α (1 + q²/α²)^{3/2}) (∫ P22 dy of the bivariate Student form).
double lambda_from_definition(Distribution kind, double theta, double alpha, int panels) {
  const double mu = 1.0 / std::tan(theta);
  const auto p2 = [&](double q) {
    const double t = q / alpha;
    if (kind == Distribution::beckmann) return std::exp(-t * t) / (alpha * std::sqrt(kPi));
    return 1.0 / (2.0 * alpha * std::pow(1.0 + t * t, 1.5));
  };
  // q = μ + w u/(1 − u): w is the decay length past μ (α²/(μ + α) for the Gaussian, μ + α for the power law).
  const double w = kind == Distribution::beckmann ? alpha * alpha / (mu + alpha) : mu + alpha;
  const QuadratureRule rule = composite_gauss_legendre(20, panels, 0.0, 1.0);
  double sum = 0.0;
  for (size_t i = 0; i < rule.nodes.size(); ++i) {
    const double u = rule.nodes[i];
    const double dq = w * u / (1.0 - u);
    sum += rule.weights[i] * dq * p2(mu + dq) * w / ((1.0 - u) * (1.0 - u));
  }
  return sum / mu;
}

TEST(MicrofacetDistribution, SmithLambdaMatchesItsDefinition) {
  for (Distribution kind : {Distribution::ggx, Distribution::beckmann}) {
    for (double alpha : {0.05, 0.2, 0.5, 1.0}) {
      for (double theta_deg : {5.0, 20.0, 45.0, 60.0, 75.0, 85.0, 89.0, 89.9}) {
        const double theta = theta_deg * kDeg;
        const double coarse = lambda_from_definition(kind, theta, alpha, 8);
        const double fine = lambda_from_definition(kind, theta, alpha, 16);
        EXPECT_TRUE(close(fine, coarse, 1e-12, 1e-18)) << name(kind) << " α=" << alpha << " θ=" << theta_deg;
        const double closed =
            kind == Distribution::ggx ? lambda_ggx_ref(theta, alpha) : lambda_beckmann_ref(theta, alpha);
        // The closed forms are the integral done analytically: agreement to 1e-10 relative (the quadrature is
        // converged to 1e-12) with an absolute floor of 1e-16 for Beckmann's Λ ≈ 0 far from grazing.
        EXPECT_TRUE(close(closed, fine, 1e-10, 1e-16)) << name(kind) << " α=" << alpha << " θ=" << theta_deg;
        // The library's Λ, isotropic and along each axis of an anisotropic lobe (Λ only sees the projected α).
        const MicrofacetDistribution iso(kind, alpha, alpha);
        // The library writes Beckmann's Λ with erf(a) − 1, which loses absolute precision ~1e-16 where Λ → 0
        // (the reference uses erfc): hence the absolute floor 1e-15; elsewhere 1e-10 as for the closed form.
        EXPECT_TRUE(close(iso.Lambda(spherical(theta, 0.4)), fine, 1e-10, 1e-15))
            << name(kind) << " α=" << alpha << " θ=" << theta_deg << " lib=" << iso.Lambda(spherical(theta, 0.4))
            << " def=" << fine;
        const MicrofacetDistribution aniso_x(kind, alpha, 0.3 * alpha), aniso_y(kind, 0.3 * alpha, alpha);
        EXPECT_TRUE(close(aniso_x.Lambda(spherical(theta, 0.0)), fine, 1e-10, 1e-15)) << name(kind);
        EXPECT_TRUE(close(aniso_y.Lambda(spherical(theta, kPiOver2)), fine, 1e-10, 1e-15)) << name(kind);
      }
    }
  }
  // Tabulated values: Beckmann at a = 1/(α tan θ) = 1, Λ = (erf 1 − 1)/2 + e⁻¹/(2 sqrt π) = 0.0251272...
  // (erf 1 = 0.8427007929497149). Λ = 1 at α tan θ = sqrt 8 for GGX: (−1 + sqrt 9)/2.
  const MicrofacetDistribution beck(Distribution::beckmann, 0.5, 0.5), ggx(Distribution::ggx, 0.5, 0.5);
  EXPECT_NEAR(beck.Lambda(spherical(std::atan(2.0), 0.0)),
              (0.8427007929497149 - 1.0) / 2 + std::exp(-1.0) / (2 * std::sqrt(kPi)), 1e-15);
  EXPECT_NEAR(ggx.Lambda(spherical(std::atan(std::sqrt(8.0) / 0.5), 0.0)), 1.0, 1e-14);
  EXPECT_EQ(ggx.Lambda({0, 0, 1}), 0.0);
  EXPECT_EQ(beck.Lambda({0, 0, 1}), 0.0);
}

// erfc⁻¹, which the Beckmann visible-slope sampler inverts its CDFs with: erfc(erfc⁻¹(q)) = q to a few ulps over
// the whole range, from q = DBL_MIN (x ≈ 26.5) through 1 (x = 0) to 2 − 2^-52 (x ≈ −5.9). Tolerance 1e-13 relative:
// erfc is well conditioned in q at these points (relative condition |x erfc'(x)/erfc(x)| ≤ 2x² ≈ 1400 at the far
// tail, against an inverse converged to 1e-15 relative in x), and std::erfc is accurate to a few ulps.
TEST(BeckmannVisible, ErfcInverseRoundTrips) {
  for (double q : {DBL_MIN, 1e-300, 1e-100, 1e-20, 1e-5, 0.01, 0.3, 0.5, 0.9, 0.999999, 1.0, 1.2, 1.5, 1.9, 1.999,
                   2.0 - 1e-10, 2.0 - 0x1.0p-52}) {
    const double x = brdf::erfc_inverse(q);
    ASSERT_TRUE(std::isfinite(x)) << q;
    EXPECT_TRUE(close(std::erfc(x), q, 1e-13, 0.0)) << "q = " << q << ", x = " << x << ", erfc(x) = " << std::erfc(x);
  }
  EXPECT_EQ(brdf::erfc_inverse(1.0), 0.0);
}

// sample_wh draws from pdf_wh: the density integrates to 1, and sample means of test functions equal their integrals
// against the density.
TEST(MicrofacetDistribution, SampleMatchesPdf) {
  const std::vector<std::function<double(const Vec3&)>> tests = {
      [](const Vec3& h) { return h.x; }, [](const Vec3& h) { return h.y; }, [](const Vec3& h) { return h.z * h.z; },
      [](const Vec3& h) { return h.x * h.y + 0.5 * h.x * h.x; },
      [](const Vec3& h) { return std::cos(8.0 * h.x) * std::sin(5.0 * h.y + 1.0); }};
  constexpr int kSamples = 40000;
  double worst_pdf = 0.0, worst_sigma = 0.0;
  for (Distribution kind : {Distribution::ggx, Distribution::beckmann}) {
    for (Lobe l : {Lobe{"iso", 0.1, 0.1}, Lobe{"iso", 0.5, 0.5}, Lobe{"iso", 1.0, 1.0}, Lobe{"aniso", 0.1, 0.4}}) {
      const MicrofacetDistribution d(kind, l.ax, l.ay);
      for (double theta_deg : {0.0, 45.0, 80.0, 89.0}) {
        const Vec3 o = spherical(theta_deg * kDeg, 0.6);
        // Both sample the visible normals (support o·h > 0: cut there), except from the normal itself, where the
        // visible normals are D cos θ_h over the whole hemisphere.
        const bool visible = theta_deg > 0.0;
        const auto cut = visible ? visible_cut(o, l.ax, l.ay) : std::function<double(double)>(no_cut);
        const std::vector<double> breaks = visible ? visible_breaks(o) : std::vector<double>{};
        const auto pdf = [&](const Vec3& h) { return d.pdf_wh(o, h); };
        const double total = integrate_hemisphere(pdf, l.ax, l.ay, cut, breaks, kFine);
        // Converged as in WeakWhiteFurnace; a density that does not integrate to 1 would bias every estimator.
        EXPECT_NEAR(total, 1.0, 1e-10) << name(kind) << " " << l.ax << "×" << l.ay << " θo=" << theta_deg;
        worst_pdf = std::fmax(worst_pdf, std::fabs(total - 1.0));

        Pcg32 rng(1234 + static_cast<uint64_t>(theta_deg), static_cast<uint64_t>(kind) * 7 + 1);
        std::vector<Vec3> hs(kSamples);
        int zero_pdf = 0;
        for (Vec3& h : hs) {
          h = d.sample_wh(o, {rng.uniform(), rng.uniform()});
          ASSERT_TRUE(is_finite(h));
          ASSERT_NEAR(length(h), 1.0, 1e-14);  // a unit normal, to rounding
          if (!(d.pdf_wh(o, h) > 0)) ++zero_pdf;
        }
        // Samples land where the density is positive (a horizon-grazing h from rounding is the only exception).
        EXPECT_LE(zero_pdf, kSamples / 10000) << name(kind) << " θo=" << theta_deg;
        for (size_t k = 0; k < tests.size(); ++k) {
          const auto& g = tests[k];
          double sum = 0.0, sum2 = 0.0;
          for (const Vec3& h : hs) {
            const double v = g(h);
            sum += v;
            sum2 += v * v;
          }
          const double mean = sum / kSamples;
          const double se = std::sqrt(std::fmax(0.0, sum2 / kSamples - mean * mean) / (kSamples - 1));
          const double expected = integrate_hemisphere([&](const Vec3& h) { return g(h) * d.pdf_wh(o, h); }, l.ax, l.ay,
                                                       cut, breaks, kCoarse);
          // 5 standard errors: for ~160 comparisons a false alarm has probability ~1e-4 (and the seed is fixed);
          // 1e-12 covers the zero-variance case (h.y ≡ 0 is not one here, but keeps the bound meaningful).
          EXPECT_LE(std::fabs(mean - expected), 5.0 * se + 1e-12)
              << name(kind) << " " << l.ax << "×" << l.ay << " θo=" << theta_deg << " test " << k << ": mean " << mean
              << " expected " << expected << " se " << se;
          if (se > 0) worst_sigma = std::fmax(worst_sigma, std::fabs(mean - expected) / se);
        }
      }
    }
  }
  std::printf("sample_wh vs pdf_wh: max |∫pdf − 1| = %.2e, max |mean − ∫g pdf| = %.2f standard errors\n", worst_pdf,
              worst_sigma);
}

// ---------------------------------------------------------------------------------------------------------------
// The BRDF.

std::vector<std::pair<Vec3, Vec3>> random_pairs(int n, uint64_t seed) {
  Pcg32 rng(seed);
  std::vector<std::pair<Vec3, Vec3>> out;
  while (static_cast<int>(out.size()) < n) {
    const Vec3 wo = sample_uniform_hemisphere({rng.uniform(), rng.uniform()});
    const Vec3 wi = sample_uniform_hemisphere({rng.uniform(), rng.uniform()});
    if (wo.z > 1e-3 && wi.z > 1e-3) out.push_back({wo, wi});
  }
  return out;
}

TEST(MicrofacetBrdf, PiNormalisationIsFourOverPiBrighter) {
  for (Distribution kind : {Distribution::ggx, Distribution::beckmann}) {
    MicrofacetParams p;
    p.distribution = kind;
    p.alpha_x = 0.3;
    p.alpha_y = 0.2;
    p.fresnel = FresnelMode::exact;
    const MicrofacetBrdf four(p);
    p.normalization = Normalization::pi;
    const MicrofacetBrdf pi(p);
    for (const auto& [wo, wi] : random_pairs(2000, 7)) {
      const double a = four.eval(wo, wi).r, b = pi.eval(wo, wi).r;
      if (a == 0.0) {
        EXPECT_EQ(b, 0.0);
        continue;
      }
      // The two differ only in the constant of the denominator: the same operations, each rounded, so the ratio is
      // 4/π to a few ulp (1e-14 relative ≈ 45 ulp).
      EXPECT_TRUE(close(b / a, 4.0 / kPi, 1e-14)) << b / a;
    }
  }
}

// Survey eq 12, written out: min(1, 2 (n·h)(n·o)/(o·h), 2 (n·h)(n·i)/(o·h)).
double vgroove_ref(const Vec3& wo, const Vec3& wi) {
  const Vec3 h = normalize(wo + wi);
  const double oh = dot(wo, h);
  return std::min({1.0, 2.0 * h.z * wo.z / oh, 2.0 * h.z * wi.z / oh});
}

TEST(MicrofacetBrdf, VGrooveIsEquation12AndAtMostOne) {
  MicrofacetParams p;
  p.distribution = Distribution::beckmann;
  p.masking = Masking::v_groove;
  const MicrofacetBrdf ct(p);
  for (const auto& [wo, wi] : random_pairs(20000, 11)) {
    const Vec3 h = normalize(wo + wi);
    const double g = g_vgroove(wo, wi, h);
    EXPECT_GE(g, 0.0);
    EXPECT_LE(g, 1.0);
    // The library takes o·h as the mean of o·h and i·h (equal in exact arithmetic; the mean makes the result
    // bit-symmetric in wo and wi). The two differ by rounding, which 1/(o·h) amplifies for large angles between wo
    // and wi: 1e-12 relative is ample for these random pairs, and far below anything a model error would produce.
    EXPECT_TRUE(close(g, vgroove_ref(wo, wi), 1e-12)) << g << " " << vgroove_ref(wo, wi);
    EXPECT_EQ(ct.G(wo, wi, h), g);
    // Reciprocal: o·h = i·h for the half vector, so swapping o and i swaps the two fractions.
    // (o − i)·h = (|o|² − |i|²)/|o + i| vanishes only up to the rounding of the unit vectors (~2ε) divided by
    // |o + i| = 2 o·h; relative to o·h that is ≈ ε/(o·h)², and G ∝ 1/(o·h) below 1.
    const double oh = dot(wo, h);
    EXPECT_TRUE(close(g_vgroove(wi, wo, h), g, 1e-15 / (oh * oh) + 1e-15)) << g_vgroove(wi, wo, h) << " " << g;
  }
  // Known values: at normal incidence on both sides nothing is shadowed; in the retro-reflection plane at θ with
  // h = o = i, G = min(1, 2 cos²θ): it is 1 up to 45°, then falls as 2 cos²θ.
  EXPECT_EQ(g_vgroove({0, 0, 1}, {0, 0, 1}, {0, 0, 1}), 1.0);
  for (double theta_deg : {30.0, 45.0 - 1e-6, 60.0, 70.0, 85.0}) {
    const Vec3 w = spherical(theta_deg * kDeg, 0.3);
    const double c = std::cos(theta_deg * kDeg);
    EXPECT_NEAR(g_vgroove(w, w, w), std::fmin(1.0, 2.0 * c * c), 1e-15);
  }
}

TEST(MicrofacetBrdf, SchlickG1AgainstExactSmithBeckmann) {
  // Schlick's eq 19 is a fit, not an oracle: measure how far it is from the exact Smith–Beckmann G1 = 1/(1 + Λ) and
  // assert the documented bound. Grid: α = 0.01..1 step 0.01, θ = 0..89.9° step 0.1°.
  double worst = 0.0, worst_alpha = 0, worst_theta = 0, worst_to_80 = 0.0, sum = 0.0;
  int n = 0;
  for (int ia = 1; ia <= 100; ++ia) {
    const double alpha = ia / 100.0;
    const MicrofacetDistribution beck(Distribution::beckmann, alpha, alpha);
    for (int it = 0; it < 900; ++it) {
      const double theta = it * 0.1 * kDeg;
      const double exact = 1.0 / (1.0 + lambda_beckmann_ref(theta, alpha));
      EXPECT_TRUE(close(beck.G1(spherical(theta, 0.0)), exact, 1e-13, 1e-16));  // the library's exact G1
      const double err = std::fabs(g1_schlick(std::cos(theta), alpha) - exact) / exact;
      sum += err;
      ++n;
      if (it <= 800) worst_to_80 = std::fmax(worst_to_80, err);
      if (err > worst) worst = err, worst_alpha = alpha, worst_theta = it * 0.1;
    }
  }
  std::printf(
      "Schlick G1 vs exact Smith-Beckmann G1: max rel err %.4f (alpha=%.2f, theta=%.1f deg), "
      "max for theta <= 80 deg %.4f, mean %.4f\n",
      worst, worst_alpha, worst_theta, worst_to_80, sum / n);
  // Documented (measured) bounds: 64.6 % at α = 1, θ = 89.9°, where both are small (0.0022 vs 0.0062); the mean over
  // the grid and the error up to 80° are much smaller. These bounds document the approximation, they are not a goal.
  EXPECT_LT(worst, 0.65);
  EXPECT_GT(worst, 0.10);  // eq 19 is a loose approximation, tens of percent off in places: if this fails it changed
  // Both are exactly 1 at normal incidence.
  for (double alpha : {0.1, 0.5, 1.0}) EXPECT_EQ(g1_schlick(1.0, alpha), 1.0);
}

TEST(MicrofacetBrdf, HeightCorrelatedSmithIsAtLeastSeparable) {
  for (Distribution kind : {Distribution::ggx, Distribution::beckmann}) {
    for (double alpha : {0.05, 0.3, 1.0}) {
      MicrofacetParams p;
      p.distribution = kind;
      p.alpha_x = alpha;
      p.alpha_y = 0.5 * alpha;
      p.masking = Masking::separable;
      const MicrofacetBrdf sep(p);
      p.masking = Masking::height_correlated;
      const MicrofacetBrdf hc(p);
      for (const auto& [wo, wi] : random_pairs(5000, 13)) {
        const Vec3 h = normalize(wo + wi);
        const double gs = sep.G(wo, wi, h), gh = hc.G(wo, wi, h);
        // 1/(1 + a + b) ≥ 1/((1 + a)(1 + b)) = 1/(1 + a + b + ab) for a, b ≥ 0; equal when ab rounds away: 1 ulp.
        EXPECT_GE(gh, gs * (1.0 - 2e-16)) << name(kind) << " α=" << alpha;
        EXPECT_LE(gh, 1.0);
        // And each is its formula in the library's Λ and G1.
        const double la = hc.distribution().Lambda(wo), lb = hc.distribution().Lambda(wi);
        EXPECT_TRUE(close(gh, 1.0 / (1.0 + la + lb), 1e-15));
        EXPECT_TRUE(close(gs, 1.0 / ((1.0 + la) * (1.0 + lb)), 1e-15));
      }
    }
  }
}

TEST(MicrofacetBrdf, NormalIncidenceClosedForm) {
  // wo = wi = n: h = n, D(n) = 1/(π α_x α_y), every G is 1 there (V-groove: min(1, 2, 2); Smith: Λ(n) = 0) and
  // F = F(1) = ((η − 1)/(η + 1))². So f = F(1) / (4 π α_x α_y) with the 4, and F(1) / (π² α_x α_y) with π.
  const Vec3 n{0, 0, 1};
  for (Model model : {Model::cook_torrance, Model::ggx, Model::beckmann}) {
    for (double eta : {1.33, 1.5, 2.4}) {
      for (auto [ax, ay] : {std::pair{0.1, 0.1}, std::pair{0.5, 0.5}, std::pair{1.0, 1.0}, std::pair{0.2, 0.6}}) {
        ModelSpec spec;
        spec.model = model;
        spec.alpha_x = ax;
        spec.alpha_y = ay;
        spec.fresnel = FresnelMode::exact;
        spec.eta = eta;
        const double f0 = ((eta - 1) / (eta + 1)) * ((eta - 1) / (eta + 1));
        // A handful of roundings on each side: 1e-14 relative.
        EXPECT_TRUE(close(make_bxdf(spec)->eval(n, n).r, f0 / (4.0 * kPi * ax * ay), 1e-14)) << to_string(model);
        spec.normalization = Normalization::pi;
        EXPECT_TRUE(close(make_bxdf(spec)->eval(n, n).g, f0 / (kPi * kPi * ax * ay), 1e-14)) << to_string(model);
      }
    }
  }
}

TEST(MicrofacetBrdf, EvalMatchesTheMicrofacetFormula) {
  // f = F(o·h) G D(h) / (4 (n·i)(n·o)) with every factor from the references above (Fresnel from the survey's eq 10).
  const auto fresnel_eq10 = [](double c, double eta) {
    const double g = std::sqrt(eta * eta + c * c - 1.0);
    const double a = (g - c) / (g + c), b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
    return 0.5 * a * a * (1.0 + b * b);
  };
  const auto theta_phi = [](const Vec3& w, double& theta, double& phi) {
    theta = std::acos(std::clamp(w.z, -1.0, 1.0));
    phi = std::atan2(w.y, w.x);
  };
  const double eta = 1.5;
  for (Distribution kind : {Distribution::ggx, Distribution::beckmann}) {
    for (Masking masking : {Masking::separable, Masking::height_correlated}) {
      for (auto [ax, ay] : {std::pair{0.1, 0.1}, std::pair{0.4, 0.4}, std::pair{0.15, 0.6}}) {
        MicrofacetParams p;
        p.distribution = kind;
        p.masking = masking;
        p.alpha_x = ax;
        p.alpha_y = ay;
        p.fresnel = FresnelMode::exact;
        p.eta = eta;
        const MicrofacetBrdf brdf(p);
        for (const auto& [wo, wi] : random_pairs(3000, 17)) {
          const Vec3 h = normalize(wo + wi);
          double th, ph, to, po, ti, pi;
          theta_phi(h, th, ph);
          theta_phi(wo, to, po);
          theta_phi(wi, ti, pi);
          const double d = kind == Distribution::ggx ? d_ggx_ref(th, ph, ax, ay) : d_beckmann_ref(th, ph, ax, ay);
          const auto lambda = [&, ax = ax, ay = ay](double t, double phi) {  // clang 14 cannot capture bindings
            const double a = alpha_along(phi, ax, ay);
            return kind == Distribution::ggx ? lambda_ggx_ref(t, a) : lambda_beckmann_ref(t, a);
          };
          const double lo = lambda(to, po), li = lambda(ti, pi);
          const double g = masking == Masking::separable ? 1.0 / ((1.0 + lo) * (1.0 + li)) : 1.0 / (1.0 + lo + li);
          const double expected = fresnel_eq10(dot(wo, h), eta) * g * d / (4.0 * wo.z * wi.z);
          // acos/atan2 round-trips and exp(−e) amplify rounding (see the pointwise D test): 1e-10 relative.
          EXPECT_TRUE(close(brdf.eval(wo, wi).r, expected, 1e-10, 1e-300))
              << name(kind) << " " << to_string(masking) << " got " << brdf.eval(wo, wi).r << " want " << expected;
        }
      }
    }
  }
}

}  // namespace
}  // namespace kiln::brdf
