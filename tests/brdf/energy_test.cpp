// Energy: the directional albedo E(wo) = ∫ f(wo, wi) cos θi dωi (brdf::directional_albedo) of the white,
// Fresnel-free form of every model (brdf::without_fresnel: F = 1, ρ = C = 1):
// - is ≤ 1 (within 5 standard errors) over θo up to 89° and a sweep of roughness, for every energy-conserving form;
// - is exactly ρ for Lambert (cosine sampling makes every weight ρ);
// - exceeds 1 where it is documented to: Cook–Torrance with the π normalisation by exactly 4/π over the 1/4 form,
//   the simplified Oren–Nayar at grazing angles as an independent 1-D quadrature of the survey's eq 27 says, the full
//   Oren–Nayar (slightly, at grazing for σ ≈ 0.1–0.2; more with the two-bounce term) as an independent 2-D quadrature
//   of the paper's formula says, and Schlick's rational D with the Beckmann Smith Λ (at grazing angles);
// - loses what single scattering loses for GGX and Beckmann at high roughness, as an independent implementation of
//   Walter et al. 2007 integrated by deterministic quadrature says;
// - agrees with a deterministic quadrature of the model's own eval() (tests/support/hemisphere.h) for smooth cases.
// The measured figures are printed with the prefix "[energy]".
//
// Statistics: the albedo estimator's standard error comes from 32 independent stratified replicates, so
// (estimate − truth) / SE follows Student's t with 31 degrees of freedom; P(|t| > 5) ≈ 2e-5 per comparison, and with
// the ~10³ comparisons here the family-wise false-failure rate stays near 1% even in the worst case that every one
// sits exactly on its bound (most are far inside).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "bakers/brdf/albedo.h"
#include "bakers/math/constants.h"
#include "bakers/math/quadrature.h"
#include "tests/support/hemisphere.h"
#include "tests/support/model_catalog.h"
#include "tests/support/tolerance.h"

namespace kiln::test {
namespace {

using brdf::Distribution;
using brdf::FresnelMode;
using brdf::Masking;
using brdf::Model;
using brdf::ModelSpec;

constexpr double kSigmas = 5.0;

double deg(double d) { return d * kPi / 180.0; }

brdf::AlbedoOptions options(int samples, uint64_t seed = 1) {
  brdf::AlbedoOptions o;
  o.samples = samples;
  o.replicates = 32;
  o.seed = seed;
  return o;
}

brdf::Estimate albedo(const brdf::Bxdf& b, double theta_o_deg, double phi_o_deg, int samples, uint64_t seed = 1) {
  return brdf::directional_albedo(b, spherical_direction(deg(theta_o_deg), deg(phi_o_deg)), options(samples, seed));
}

// ---------------------------------------------------------------------------------------------------------------
// The quadrature helper itself, on integrals known in closed form. Tolerance 1e-12: composite Gauss–Legendre of
// order 8 on smooth integrands converges to rounding level here (checked by halving the panel count: same to 1e-14).

TEST(HemisphereQuadrature, IntegratesKnownFunctions) {
  const DirectionRule r = hemisphere_rule(8, 8);
  EXPECT_NEAR(integrate(r, [](const Vec3&) { return 1.0; }), 2 * kPi, 1e-12);
  EXPECT_NEAR(integrate(r, [](const Vec3& w) { return w.z; }), kPi, 1e-12);
  EXPECT_NEAR(integrate(r, [](const Vec3& w) { return std::pow(w.z, 10); }), 2 * kPi / 11, 1e-12);
  EXPECT_NEAR(integrate(r, [](const Vec3& w) { return w.x * w.x; }), 2 * kPi / 3, 1e-12);
  EXPECT_NEAR(integrate(r, [](const Vec3& w) { return w.x * w.y + w.y; }), 0.0, 1e-12);
  // The adaptive cell rule: ∫ over the quarter θ ∈ [0, π/4], φ ∈ [0, π/2] of cos θ = (π/2) · sin²(π/4) / 2 · 2.
  const CellIntegral c = integrate_cell([](const Vec3& w) { return w.z; }, 0, kPiOver4, 0, kPiOver2, 1e-12, 1e-15);
  EXPECT_NEAR(c.value, kPiOver2 * 0.5 * std::pow(std::sin(kPiOver4), 2), 1e-12);
}

// ---------------------------------------------------------------------------------------------------------------
// Lambert: weight = (ρ/π) cos θi / (cos θi / π) = ρ for every sample, so E = ρ and the spread of the replicates is 0,
// up to rounding: a few ulps per weight (1e-15 relative), and the one-pass variance sum_sq/n − mean² of the albedo
// estimator, whose cancellation leaves up to ~sqrt(1e-16) ≈ 1e-8 of spurious standard error.

TEST(Energy, LambertAlbedoIsExactlyRho) {
  ModelSpec s;
  s.model = Model::lambert;
  s.albedo = Rgb(0.9, 0.5, 0.1);
  const auto b = brdf::make_bxdf(s);
  for (double t : {0.0, 30.0, 60.0, 85.0, 89.0}) {
    const brdf::Estimate e = albedo(*b, t, 10.0, 4096);
    for (int ch = 0; ch < 3; ++ch) {
      EXPECT_TRUE(close(e.value[ch], s.albedo[ch], 1e-13))
          << "theta_o " << t << " channel " << ch << ": " << e.value[ch];
      EXPECT_LE(e.std_error[ch], 1e-7) << "theta_o " << t << " channel " << ch;
    }
    std::cout << "[energy] lambert rho=(0.9,0.5,0.1) theta_o=" << t << ": E = (" << e.value.r << ", " << e.value.g
              << ", " << e.value.b << "), reported standard error " << e.std_error.max() << "\n";
  }
}

// ---------------------------------------------------------------------------------------------------------------
// E ≤ 1 for every energy-conserving entry over θo and a roughness sweep.

const double kThetas[] = {0.0, 30.0, 60.0, 75.0, 85.0, 89.0};

std::vector<double> roughness_sweep(const ModelSpec& s) {
  switch (s.model) {
    case Model::cook_torrance:
    case Model::ggx:
    case Model::beckmann:
      return {0.05, 0.2, 0.5, 1.0};
    // Oren–Nayar conserves energy only at some σ (the first-order fit exceeds 1 by up to 0.4% at grazing angles for
    // σ ≈ 0.1–0.2): each entry is checked at its own σ, and OrenNayarGrazing below measures the σ dependence.
    case Model::oren_nayar:
    case Model::oren_nayar_simple:
      return {};
    case Model::schlick:
    case Model::schlick_double:
      return {0.0, 0.05, 0.3, 1.0};
    case Model::lambert:
      return {};
  }
  return {};
}

std::vector<const CatalogEntry*> conserving_entries() {
  std::vector<const CatalogEntry*> out;
  for (const CatalogEntry& e : model_catalog())
    if (e.energy_conserving) out.push_back(&e);
  return out;
}

class EnergyConservationTest : public ::testing::TestWithParam<const CatalogEntry*> {};

TEST_P(EnergyConservationTest, AlbedoAtMostOne) {
  const CatalogEntry& entry = *GetParam();
  // Configurations already swept by an earlier entry (the Fresnel variants become identical once white) are skipped.
  static std::set<std::string> seen;
  std::vector<ModelSpec> specs{brdf::without_fresnel(entry.spec)};
  if (!entry.anisotropic)
    for (double r : roughness_sweep(entry.spec)) specs.push_back(brdf::with_roughness(specs.front(), r));
  const std::vector<double> phis = entry.anisotropic ? std::vector<double>{0.0, 45.0, 90.0} : std::vector<double>{0.0};
  double max_e = -1, max_se = 0, max_theta = 0, max_phi = 0;
  std::string max_what;
  int evaluated = 0;
  for (const ModelSpec& spec : specs) {
    const auto b = brdf::make_bxdf(spec);
    if (!seen.insert(b->describe()).second) continue;
    for (double phi : phis) {
      for (double t : kThetas) {
        const brdf::Estimate e = albedo(*b, t, phi, 8192);
        ++evaluated;
        const double v = e.value.max(), se = e.std_error.max();
        // 1e-12: rounding of forms whose E is exactly 1 (σ = 0 Oren–Nayar, Schlick r = 1) with a zero spread.
        EXPECT_LE(v, 1.0 + kSigmas * se + 1e-12)
            << b->describe() << " at theta_o " << t << ", phi_o " << phi << ": E = " << v << " +- " << se;
        if (v > max_e) max_e = v, max_se = se, max_theta = t, max_phi = phi, max_what = b->describe();
      }
    }
  }
  if (evaluated > 0) {
    std::cout << "[energy] max E of " << entry.name << " family: " << max_e << " +- " << max_se << " (" << max_what
              << ", theta_o " << max_theta << ", phi_o " << max_phi << ")\n";
  }
}

INSTANTIATE_TEST_SUITE_P(Catalog, EnergyConservationTest, ::testing::ValuesIn(conserving_entries()),
                         [](const ::testing::TestParamInfo<const CatalogEntry*>& info) { return info.param->name; });

// ---------------------------------------------------------------------------------------------------------------
// Cook–Torrance with the π normalisation: f_π = (4/π) f_4 exactly, and the sampling does not depend on the
// normalisation, so with the same sample stream E_π = (4/π) E_4 to rounding (a few ulps per weight, relative 1e-12
// leaves ample room for the sums). Since E_4 ≤ 1 (checked above) and E_4 → 1 for smooth surfaces at normal
// incidence, the excess approaches 4/π − 1 = 27.3%: the measured maximum is printed and asserted to be in that range.

TEST(Energy, CookTorrancePiNormalisationExcess) {
  double max_e = 0, max_se = 0, max_alpha = 0, max_theta = 0;
  for (double alpha : {0.05, 0.1, 0.3, 0.5, 1.0}) {
    ModelSpec s;
    s.model = Model::cook_torrance;
    s.alpha_x = s.alpha_y = alpha;
    s = brdf::without_fresnel(s);
    s.normalization = brdf::Normalization::four;
    const auto b4 = brdf::make_bxdf(s);
    s.normalization = brdf::Normalization::pi;
    const auto bpi = brdf::make_bxdf(s);
    for (double t : kThetas) {
      const brdf::Estimate e4 = albedo(*b4, t, 0, 16384), epi = albedo(*bpi, t, 0, 16384);
      EXPECT_TRUE(close(epi.value.r, 4.0 / kPi * e4.value.r, 1e-12))
          << "alpha " << alpha << " theta_o " << t << ": E_pi " << epi.value.r << ", E_4 " << e4.value.r;
      std::printf("[energy] cook-torrance alpha=%-4g theta_o=%-2g: E_4 = %.4f +- %.4f, E_pi = %.4f +- %.4f\n", alpha, t,
                  e4.value.r, e4.std_error.r, epi.value.r, epi.std_error.r);
      if (epi.value.r > max_e) max_e = epi.value.r, max_se = epi.std_error.r, max_alpha = alpha, max_theta = t;
    }
  }
  std::printf("[energy] cook-torrance normalization=pi: max E = %.4f +- %.4f (excess %.1f%%) at alpha %g, theta_o %g\n",
              max_e, max_se, 100 * (max_e - 1), max_alpha, max_theta);
  // The excess is real (far beyond the estimator's error) and bounded by 4/π.
  EXPECT_GT(max_e, 1.2 + kSigmas * max_se);
  EXPECT_LE(max_e, 4.0 / kPi + kSigmas * max_se + 1e-12);
}

// ---------------------------------------------------------------------------------------------------------------
// The simplified Oren–Nayar (survey eq 27) against an independent reduction of its albedo to one dimension:
// f = ρ/π (A + B max(0, cos Δφ) sin α tan β), and ∫ max(0, cos Δφ) dΔφ = 2, so
//   E(θo) = ρ [A + (2B/π) ∫₀^{π/2} sin(max(θi, θo)) tan(min(θi, θo)) cos θi sin θi dθi],
// integrated by Gauss–Legendre on [0, θo] and [θo, π/2] where the integrand is smooth (error at rounding level:
// the 32- and 64-node results agree to 1e-14). At θo = 90° the integral is ∫ sin² = π/4: E = A + B/2, largest for
// σ² ≈ 0.0394 (σ ≈ 0.20): 1.0152.

double oren_nayar_simple_albedo(double sigma, double theta_o, int nodes) {
  const double s2 = sigma * sigma;
  const double A = 1.0 - 0.5 * s2 / (s2 + 0.33), B = 0.45 * s2 / (s2 + 0.09);
  const auto integrand = [&](double ti) {
    return std::sin(std::max(ti, theta_o)) * std::tan(std::min(ti, theta_o)) * std::cos(ti) * std::sin(ti);
  };
  double integral = 0;
  for (auto [a, b] : {std::pair{0.0, theta_o}, std::pair{theta_o, kPiOver2}}) {
    if (b <= a) continue;
    const QuadratureRule r = gauss_legendre(nodes, a, b);
    for (size_t k = 0; k < r.nodes.size(); ++k) integral += r.weights[k] * integrand(r.nodes[k]);
  }
  return A + 2.0 * B / kPi * integral;
}

TEST(Energy, OrenNayarSimpleGrazingExcess) {
  // The reference's own convergence.
  for (double t : {0.0, 45.0, 89.0}) {
    EXPECT_NEAR(oren_nayar_simple_albedo(0.2, deg(t), 32), oren_nayar_simple_albedo(0.2, deg(t), 64), 1e-13);
  }
  EXPECT_NEAR(oren_nayar_simple_albedo(0.2, kPiOver2, 64), 1.0152, 1e-4);  // A + B/2 (see above)

  double max_e = 0, max_se = 0, max_sigma = 0, max_theta = 0, max_ref = 0;
  for (double sigma : {0.1, 0.2, 0.3, 0.5, 1.0}) {
    ModelSpec s;
    s.model = Model::oren_nayar_simple;
    s.sigma = sigma;
    const auto b = brdf::make_bxdf(brdf::without_fresnel(s));
    for (double t : {0.0, 30.0, 60.0, 80.0, 85.0, 89.0, 89.9}) {
      const brdf::Estimate e = albedo(*b, t, 0, 65536);
      const double ref = oren_nayar_simple_albedo(sigma, deg(t), 64);
      EXPECT_NEAR(e.value.r, ref, kSigmas * e.std_error.r + 1e-12) << "sigma " << sigma << ", theta_o " << t;
      std::printf("[energy] oren-nayar-simple sigma=%-4g theta_o=%-4g: E = %.5f +- %.5f, reference %.5f\n", sigma, t,
                  e.value.r, e.std_error.r, ref);
      if (e.value.r > max_e) max_e = e.value.r, max_se = e.std_error.r, max_sigma = sigma, max_theta = t, max_ref = ref;
    }
  }
  std::printf("[energy] oren-nayar-simple: max E = %.5f +- %.5f (reference %.5f) at sigma %g, theta_o %g\n", max_e,
              max_se, max_ref, max_sigma, max_theta);
  // The documented excess (eq 27 is slightly above 1 at grazing for some σ) is there, and no larger than the
  // θo → 90° supremum A + B/2 ≤ 1.0152.
  EXPECT_GT(max_e, 1.0 + kSigmas * max_se);
  EXPECT_LE(max_e, 1.0152 + kSigmas * max_se);
}

// ---------------------------------------------------------------------------------------------------------------
// Single-scattering loss of GGX and Beckmann against an independent implementation of Walter et al. 2007
// (isotropic D with its Smith Λ, separable or height-correlated G) integrated over wi by composite Gauss–Legendre:
//   E(wo) = ∫ D(h) G(wo, wi) / (4 cos θo) dωi.
// The reference's quadrature error is estimated by doubling the panels; the comparison allows 5 standard errors of
// the estimator plus twice that estimate.

enum class RefD { ggx, beckmann, schlick /* Schlick's rational Beckmann (survey eq 20, / π), with Beckmann's Λ */ };

struct ReferenceMicrofacet {
  RefD d;
  bool height_correlated;
  double alpha;

  double D(double c) const {
    if (!(c > 0)) return 0;
    const double c2 = c * c, t2 = (1 - c2) / c2, a2 = alpha * alpha;
    if (d == RefD::ggx) {
      const double k = 1 + t2 / a2;
      return 1.0 / (kPi * a2 * c2 * c2 * k * k);
    }
    if (d == RefD::schlick) {
      const double m = alpha, x = c + m - 1;
      if (x <= 0) return 0;
      const double q = m * x * x - x * x + m * m;
      return m * m * m * x / (c * q * q) / kPi;
    }
    return std::exp(-t2 / a2) / (kPi * a2 * c2 * c2);
  }
  double Lambda(double c) const {
    const double t = std::sqrt(std::fmax(0.0, 1 - c * c)) / c;
    if (t == 0) return 0;
    if (d == RefD::ggx) return 0.5 * (std::sqrt(1 + alpha * alpha * t * t) - 1);
    const double a = 1 / (alpha * t);
    return 0.5 * (std::erf(a) - 1) + std::exp(-a * a) / (2 * a * std::sqrt(kPi));
  }
  // f cos θi.
  double integrand(const Vec3& wo, const Vec3& wi) const {
    if (!(wi.z > 0)) return 0;
    const Vec3 h = normalize(wo + wi);
    const double lo = Lambda(wo.z), li = Lambda(wi.z);
    const double G = height_correlated ? 1 / (1 + lo + li) : 1 / ((1 + lo) * (1 + li));
    return D(h.z) * G / (4 * wo.z);
  }
};

struct QuadratureValue {
  double value, error;
};

// ∫ g(wi) dωi with breakpoints at θo (the lobe sits near the mirror direction) and at the azimuths of wo and of its
// mirror image; error estimated from the same rule with twice the panels.
template <typename G>
QuadratureValue quadrature_albedo(const G& g, double theta_o, double phi_o, int panels) {
  const auto run = [&](int p) {
    return integrate(hemisphere_rule(p, 8, {theta_o}, {phi_o, std::fmod(phi_o + kPi, 2 * kPi)}), g);
  };
  const double coarse = run(panels), fine = run(2 * panels);
  return {fine, std::fabs(fine - coarse)};
}

// GGX with α = 1 has D = 1/π and Λ(θ) = (1/cos θ − 1)/2, so at normal incidence E = ∫ (1/π) G1(wi) / 4 dωi
// = ∫₀¹ μ / (1 + μ) dμ = 1 − ln 2 (with either masking form, as Λ(wo) = 0): single scattering loses ln 2 = 69.3%.
TEST(Energy, GgxAlphaOneNormalIncidenceIsOneMinusLn2) {
  for (Masking m : {Masking::separable, Masking::height_correlated}) {
    ModelSpec s;
    s.model = Model::ggx;
    s.alpha_x = s.alpha_y = 1.0;
    s.masking = m;
    const auto b = brdf::make_bxdf(brdf::without_fresnel(s));
    const brdf::Estimate e = albedo(*b, 0.0, 0.0, 65536);
    EXPECT_NEAR(e.value.r, 1.0 - std::log(2.0), kSigmas * e.std_error.r + 1e-12) << b->describe();
    const ReferenceMicrofacet ref{RefD::ggx, m == Masking::height_correlated, 1.0};
    const Vec3 n{0, 0, 1};
    // The independent reference's quadrature, too (smooth integrand: rounding-level agreement).
    EXPECT_NEAR(quadrature_albedo([&](const Vec3& wi) { return ref.integrand(n, wi); }, 0, 0, 24).value,
                1.0 - std::log(2.0), 1e-10);
  }
}

TEST(Energy, MicrofacetSingleScatteringLoss) {
  for (bool ggx : {true, false}) {
    for (bool hc : {false, true}) {
      double previous_loss_at_normal = -1;
      for (double alpha : {0.3, 0.6, 1.0}) {
        ModelSpec s;
        s.model = ggx ? Model::ggx : Model::beckmann;
        s.alpha_x = s.alpha_y = alpha;
        s.masking = hc ? Masking::height_correlated : Masking::separable;
        const auto b = brdf::make_bxdf(brdf::without_fresnel(s));
        const ReferenceMicrofacet ref{ggx ? RefD::ggx : RefD::beckmann, hc, alpha};
        for (double t : {0.0, 45.0, 80.0, 89.0}) {
          const Vec3 wo = spherical_direction(deg(t), 0);
          const QuadratureValue q =
              quadrature_albedo([&](const Vec3& wi) { return ref.integrand(wo, wi); }, deg(t), 0, 16);
          const brdf::Estimate e = albedo(*b, t, 0, 32768);
          EXPECT_NEAR(e.value.r, q.value, kSigmas * e.std_error.r + 2 * q.error + 1e-9)
              << b->describe() << " at theta_o " << t;
          std::printf(
              "[energy] %s %s alpha=%-3g theta_o=%-2g: E = %.4f +- %.4f, reference %.5f (quadrature +- %.1e), "
              "loss 1 - E = %.4f\n",
              ggx ? "ggx     " : "beckmann", hc ? "height-correlated" : "separable        ", alpha, t, e.value.r,
              e.std_error.r, q.value, q.error, 1 - q.value);
          // Single scattering loses energy, more for rougher surfaces.
          EXPECT_LT(q.value, 1.0);
          if (t == 0.0) {
            EXPECT_GT(1 - q.value, previous_loss_at_normal) << "loss must grow with alpha";
            previous_loss_at_normal = 1 - q.value;
          }
        }
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------------------------
// Schlick's rational Beckmann D (survey eq 20) is normalised (∫ D cos θh dωh = 1 exactly: with x = t + m − 1 the
// integral is 2m³ ∫₀^m x / ((m − 1)x² + m²)² dx = 1), but paired with the Beckmann Smith Λ it under-masks: for m = 1
// it is the constant 1/π (GGX's D at α = 1), whose own Λ is GGX's, much larger at grazing than Beckmann's. So E > 1 at
// grazing angles. Measured deterministically: the quadrature of the model's eval against the same rule applied to an
// independent implementation (same nodes, so they agree to rounding unless the formulas differ; allowed: twice the
// sum of their refinement differences). directional_albedo's figures are printed alongside for comparison.

TEST(Energy, SchlickBeckmannDistributionExcess) {
  double max_e = 0;
  std::string max_what;
  for (double alpha : {0.2, 0.5, 1.0}) {
    for (bool hc : {false, true}) {
      ModelSpec s;
      s.model = Model::beckmann;
      s.distribution = Distribution::schlick_beckmann;
      s.alpha_x = s.alpha_y = alpha;
      s.masking = hc ? Masking::height_correlated : Masking::separable;
      const auto b = brdf::make_bxdf(brdf::without_fresnel(s));
      const ReferenceMicrofacet ref{RefD::schlick, hc, alpha};
      for (double t : {0.0, 60.0, 85.0, 89.0}) {
        const Vec3 wo = spherical_direction(deg(t), 0);
        const QuadratureValue qr =
            quadrature_albedo([&](const Vec3& wi) { return ref.integrand(wo, wi); }, deg(t), 0, 16);
        const QuadratureValue qm =
            quadrature_albedo([&](const Vec3& wi) { return b->eval(wo, wi).r * wi.z; }, deg(t), 0, 16);
        EXPECT_NEAR(qm.value, qr.value, 2 * (qr.error + qm.error) + 1e-9) << b->describe() << " at theta_o " << t;
        const brdf::Estimate e = albedo(*b, t, 0, 16384);
        std::printf(
            "[energy] schlick-beckmann D %s alpha=%-3g theta_o=%-2g: E = %.4f (quadrature of eval, +- %.1e; "
            "reference %.4f); Monte Carlo %.4f +- %.4f\n",
            hc ? "height-correlated" : "separable        ", alpha, t, qm.value, qm.error, qr.value, e.value.r,
            e.std_error.r);
        if (qm.value > max_e) max_e = qm.value, max_what = b->describe() + " at theta_o " + std::to_string(t);
      }
    }
  }
  std::printf("[energy] schlick-beckmann D: max E = %.4f (%s)\n", max_e, max_what.c_str());
  EXPECT_GT(max_e, 1.1);  // the excess is real (and far beyond the quadrature error)
}

// ---------------------------------------------------------------------------------------------------------------
// The full Oren–Nayar model (first order, and with the two-bounce term, ρ = 1) against an independent 2-D quadrature
// of the paper's formula (written here with angles: θ = acos, Δφ = atan2), with breakpoints at its kinks (θi = θo;
// Δφ = ±90°, where |cos Δφ| and the C2 branch switch) and the same clamp at 0 the model documents. The first-order
// fit exceeds 1 at grazing angles for small σ (up to ≈ 1.0037 near σ = 0.14 as θo → 90°), contrary to the
// survey's section 6, which calls it energy conserving; the two-bounce term adds up to ≈ 5% (σ ≈ 0.3, θo → 90°).

double oren_nayar_integrand(double sigma, bool ir, double theta_o, const Vec3& wi) {
  const double s2 = sigma * sigma;
  const double c1 = 1 - 0.5 * s2 / (s2 + 0.33), k2 = 0.45 * s2 / (s2 + 0.09), k3 = 0.125 * s2 / (s2 + 0.09),
               k4 = 0.17 * s2 / (s2 + 0.13);
  const double ti = std::acos(std::clamp(wi.z, -1.0, 1.0));
  const double a = std::max(ti, theta_o), b = std::min(ti, theta_o);
  const double c = std::cos(std::atan2(wi.y, wi.x));  // wo at φ = 0
  const double c2 = c >= 0 ? k2 * std::sin(a) : k2 * (std::sin(a) - std::pow(2 * b / kPi, 3));
  const double c3 = k3 * std::pow(4 * a * b / (kPi * kPi), 2);
  double v = std::max(0.0, c1 + c * c2 * std::tan(b) + (1 - std::fabs(c)) * c3 * std::tan((a + b) / 2));
  if (ir) v += k4 * (1 - c * std::pow(2 * b / kPi, 2));
  return v / kPi * wi.z;
}

TEST(Energy, OrenNayarGrazing) {
  for (bool ir : {false, true}) {
    double max_e = 0, max_se = 0, max_ref = 0, max_sigma = 0, max_theta = 0;
    for (double sigma : {0.1, 0.14, 0.2, 0.3, 0.5, 1.0, kPiOver2}) {
      ModelSpec s;
      s.model = Model::oren_nayar;
      s.sigma = sigma;
      s.interreflection = ir;
      const auto b = brdf::make_bxdf(brdf::without_fresnel(s));
      for (double t : {0.0, 60.0, 85.0, 89.0, 89.9}) {
        const auto run = [&](int panels) {
          const DirectionRule r =
              direction_rule({0, deg(t), kPiOver2}, {0, kPiOver2, kPi, 3 * kPiOver2, 2 * kPi}, panels, 8);
          return integrate(r, [&](const Vec3& wi) { return oren_nayar_integrand(sigma, ir, deg(t), wi); });
        };
        const double coarse = run(6), ref = run(12), qerr = std::fabs(ref - coarse);
        const brdf::Estimate e = albedo(*b, t, 0, 32768);
        EXPECT_NEAR(e.value.r, ref, kSigmas * e.std_error.r + 2 * qerr + 1e-9) << b->describe() << " theta_o " << t;
        std::printf("[energy] oren-nayar%s sigma=%-6.4g theta_o=%-4g: E = %.5f +- %.5f, reference %.5f (+- %.1e)\n",
                    ir ? " +interreflection" : "                 ", sigma, t, e.value.r, e.std_error.r, ref, qerr);
        if (ref > max_ref) max_ref = ref, max_e = e.value.r, max_se = e.std_error.r, max_sigma = sigma, max_theta = t;
      }
    }
    std::printf("[energy] oren-nayar%s: max E = %.5f +- %.5f (reference %.5f) at sigma %g, theta_o %g\n",
                ir ? " with interreflection" : " first order", max_e, max_se, max_ref, max_sigma, max_theta);
    // What the formula does (independent quadrature): the excess exists and stays within these bounds.
    EXPECT_GT(max_ref, 1.0);
    EXPECT_LT(max_ref, ir ? 1.06 : 1.005);
  }
}

// ---------------------------------------------------------------------------------------------------------------
// Schlick's models deterministically: their importance sampling leaves a standard error of ~5e-3 at 8192 samples
// (against ~1e-4 for GGX), which makes the Monte Carlo sweep above a weak check. kiln's single layer is built so that
// with C = 1 the albedo is exactly 1 (schlick.cpp: f_ms gives back what masking removes, from tabulated E(wo)). The
// double layer is tested with a dielectric-like top (C = 0.04; a white top reflects everything and hides the bottom)
// over a white bottom: it loses the light the layers exchange, so E ≤ 1. The quadrature (panels doubled for the error
// estimate) has breakpoints at θo and at the azimuths of wo and its mirror (the lobe's peak). Allowed: 1e-3 over 1
// for the tables' interpolation, still far below a real excess (the printed eq 23 grows like 1/(2 cos θo)).

TEST(Energy, SchlickAlbedoByQuadrature) {
  double worst_single = 0, min_double = 1, max_double = 0;
  for (bool dbl : {false, true}) {
    for (double r : dbl ? std::vector<double>{0.1, 0.5} : std::vector<double>{0.05, 0.5, 1.0}) {
      for (double p : {0.3, 1.0}) {
        ModelSpec s;
        s.model = dbl ? Model::schlick_double : Model::schlick;
        s.layer.r = r;
        s.layer.p = p;
        s.bottom_layer.r = 0.8;
        s = brdf::without_fresnel(s);
        if (dbl) s.layer.c = Rgb(0.04);
        const auto b = brdf::make_bxdf(s);
        for (double t : {0.0, 60.0, 89.0}) {
          const double phi = p < 1 ? 30.0 : 0.0;
          const Vec3 wo = spherical_direction(deg(t), deg(phi));
          const QuadratureValue q =
              quadrature_albedo([&](const Vec3& wi) { return b->eval(wo, wi).r * wi.z; }, deg(t), deg(phi), 12);
          EXPECT_LE(q.value, 1.0 + 1e-3 + 2 * q.error) << b->describe() << " theta_o " << t;
          if (!dbl) {
            EXPECT_NEAR(q.value, 1.0, 1e-3 + 2 * q.error) << b->describe() << " theta_o " << t;
            worst_single = std::max(worst_single, std::fabs(q.value - 1));
          } else {
            min_double = std::min(min_double, q.value);
            max_double = std::max(max_double, q.value);
          }
          std::printf("[energy] %s r=%-4g p=%-3g theta_o=%-2g: E = %.6f (quadrature of eval, +- %.1e)\n",
                      dbl ? "schlick-double (top C=0.04, bottom C=1 r=0.8)" : "schlick", r, p, t, q.value, q.error);
        }
      }
    }
  }
  std::printf("[energy] schlick single layer, C = 1: max |E - 1| = %.2e; double layer: E in [%.4f, %.4f]\n",
              worst_single, min_double, max_double);
}

// ---------------------------------------------------------------------------------------------------------------
// directional_albedo against a deterministic quadrature of the model's own eval() for smooth cases (α ≥ 0.3, and the
// diffuse models with breakpoints at their kinks: θi = θo for max/min, Δφ = ±90° for max(0, cos Δφ) and |cos Δφ|).

TEST(Energy, AlbedoMatchesQuadratureOfEval) {
  struct Case {
    std::string name;
    ModelSpec spec;
    double theta, phi;
  };
  std::vector<Case> cases;
  const auto microfacet = [](Model m, double a, Masking g) {
    ModelSpec s;
    s.model = m;
    s.alpha_x = s.alpha_y = a;
    s.masking = g;
    return s;
  };
  cases.push_back({"ggx a=0.3 separable", microfacet(Model::ggx, 0.3, Masking::separable), 0, 0});
  cases.push_back({"ggx a=0.3 separable", microfacet(Model::ggx, 0.3, Masking::separable), 60, 30});
  cases.push_back({"ggx a=1 height-correlated", microfacet(Model::ggx, 1.0, Masking::height_correlated), 80, 200});
  cases.push_back({"beckmann a=0.5 separable", microfacet(Model::beckmann, 0.5, Masking::separable), 45, 100});
  {
    ModelSpec s = microfacet(Model::ggx, 0.3, Masking::separable);
    s.alpha_y = 0.6;
    cases.push_back({"ggx a=(0.3,0.6) separable", s, 50, 45});
  }
  {
    ModelSpec s;
    s.model = Model::oren_nayar;
    s.sigma = 0.5;
    cases.push_back({"oren-nayar sigma=0.5", s, 60, 0});
    s.interreflection = true;
    cases.push_back({"oren-nayar sigma=0.5 interreflection", s, 30, 0});
    s.model = Model::oren_nayar_simple;
    s.interreflection = false;
    cases.push_back({"oren-nayar-simple sigma=0.3", s, 70, 0});
  }
  {
    ModelSpec s;
    s.model = Model::schlick;
    s.layer.r = 0.5;
    s.layer.p = 1.0;
    cases.push_back({"schlick r=0.5 p=1", s, 40, 0});
  }
  for (const Case& c : cases) {
    const auto b = brdf::make_bxdf(brdf::without_fresnel(c.spec));
    const Vec3 wo = spherical_direction(deg(c.theta), deg(c.phi));
    const double po = deg(c.phi);
    // Breakpoints: θo; the azimuth of wo, its mirror, and ±90° from it.
    const auto run = [&](int panels) {
      const DirectionRule r = hemisphere_rule(
          panels, 8, {deg(c.theta)},
          {po, std::fmod(po + kPiOver2, 2 * kPi), std::fmod(po + kPi, 2 * kPi), std::fmod(po + 3 * kPiOver2, 2 * kPi)});
      return integrate(r, [&](const Vec3& wi) { return b->eval(wo, wi).r * wi.z; });
    };
    const double coarse = run(12), fine = run(24);
    const brdf::Estimate e = brdf::directional_albedo(*b, wo, options(65536));
    EXPECT_NEAR(e.value.r, fine, kSigmas * e.std_error.r + 2 * std::fabs(fine - coarse) + 1e-9)
        << c.name << " at theta_o " << c.theta;
    std::printf("[energy] %s theta_o=%g: directional_albedo %.5f +- %.5f, quadrature of eval %.6f (+- %.1e)\n",
                c.name.c_str(), c.theta, e.value.r, e.std_error.r, fine, std::fabs(fine - coarse));
  }
}

}  // namespace
}  // namespace kiln::test
