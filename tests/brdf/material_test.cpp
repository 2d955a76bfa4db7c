// Materials: a diffuse and a specular lobe combined by weights or by layering, keeping energy.
#include "bakers/brdf/material.h"

#include <gtest/gtest.h>

#include <cmath>

#include "bakers/brdf/albedo.h"
#include "bakers/math/rng.h"

namespace kiln::brdf {
namespace {

ModelSpec lambert(double rho) {
  ModelSpec s;
  s.model = Model::lambert;
  s.albedo = Rgb{rho};
  return s;
}

ModelSpec ggx(double alpha, FresnelMode fresnel, double f0) {
  ModelSpec s;
  s.model = Model::ggx;
  s.alpha_x = s.alpha_y = alpha;
  s.fresnel = fresnel;
  s.f0 = Rgb{f0};
  return s;
}

Vec3 from_mu(double mu, double phi = 0.3) {
  const double s = std::sqrt(1.0 - mu * mu);
  return {s * std::cos(phi), s * std::sin(phi), mu};
}

AlbedoOptions many() {
  AlbedoOptions o;
  o.samples = 1 << 15;
  return o;
}

TEST(Material, ValidationNamesTheLobe) {
  MaterialSpec m{lambert(0.5), ggx(0.3, FresnelMode::none, 0.04), Combine::layered, 0.5};
  m.specular.alpha_x = -1;
  ASSERT_TRUE(validate(m).has_value());
  EXPECT_EQ(std::string(validate(m)->what()).rfind("specular.alpha_x", 0), 0u) << validate(m)->what();
  m = MaterialSpec{lambert(2.0), ggx(0.3, FresnelMode::none, 0.04), Combine::weights, 0.5};
  EXPECT_EQ(std::string(validate(m)->what()).rfind("diffuse.albedo", 0), 0u) << validate(m)->what();
  m = MaterialSpec{lambert(0.5), ggx(0.3, FresnelMode::none, 0.04), Combine::weights, 1.5};
  EXPECT_EQ(std::string(validate(m)->what()).rfind("specular_weight", 0), 0u) << validate(m)->what();
  EXPECT_THROW(Material{m}, std::invalid_argument);
}

// Weights: the albedo is linear in the lobes, d E_d + s E_s, and with white conserving lobes at most 1.
TEST(Material, WeightsAreLinearInTheLobes) {
  const MaterialSpec spec{lambert(1.0), ggx(0.4, FresnelMode::none, 1.0), Combine::weights, 0.3};
  const Material m(spec);
  const auto spec_lobe = make_bxdf(spec.specular);
  for (double mu : {0.1, 0.5, 0.95}) {
    const Estimate e = directional_albedo(m, mu, many());
    const Estimate es = directional_albedo(*spec_lobe, mu, many());
    const double expected = 0.7 * 1.0 + 0.3 * es.value.r;
    // Two independent Monte Carlo estimates: 5 combined standard errors.
    EXPECT_NEAR(e.value.r, expected, 5 * std::hypot(e.std_error.r, 0.3 * es.std_error.r)) << "mu " << mu;
    EXPECT_LE(e.value.r, 1.0 + 5 * e.std_error.r);
  }
}

// Layering: albedo = E_s(μo) + (1 − E_s(μo)) ∫ (1 − E_s(μi)) f_d cos ≤ 1; for a white Lambertian base the integral
// is (1 − Ē_s), so the albedo is E_s + (1 − E_s)(1 − Ē_s): the loss (1 − E_s) Ē_s is the light the interface would
// reflect back down, which this form does not return. Check both the bound and that closed form.
TEST(Material, LayeredConservesEnergyAndLosesOnlyTheInternalReflection) {
  for (double alpha : {0.05, 0.3, 0.8}) {
    for (double f0 : {0.04, 0.5}) {
      const MaterialSpec spec{lambert(1.0), ggx(alpha, FresnelMode::schlick, f0), Combine::layered, 0.0};
      const Material m(spec);
      // Ē_s from the material's own table, by the midpoint rule on its 32 nodes: its error (~1e-4) is far below
      // the Monte Carlo tolerance used below.
      double e_avg = 0;
      for (int i = 0; i < 32; ++i) {
        const double mu = (i + 0.5) / 32;
        e_avg += 2.0 * mu * m.specular_albedo(mu).r / 32;
      }
      for (double mu : {0.05, 0.4, 1.0}) {
        const Estimate e = directional_albedo(m, from_mu(mu), many());
        const double es = m.specular_albedo(mu).r;
        const double expected = es + (1.0 - es) * (1.0 - e_avg);
        // Tolerance: 5 standard errors of this estimate plus 0.01 for the tabulated E_s (2048 samples per node,
        // interpolated), which enters both the material and the expected value.
        EXPECT_NEAR(e.value.r, expected, 5 * e.std_error.r + 0.01) << "alpha " << alpha << " f0 " << f0 << " mu " << mu;
        EXPECT_LE(e.value.r, 1.0 + 5 * e.std_error.r) << "alpha " << alpha << " f0 " << f0 << " mu " << mu;
        std::cout << "[ measured ] layered ggx(alpha=" << alpha << ", f0=" << f0 << ") over white lambert, mu=" << mu
                  << ": albedo " << e.value.r << ", lost to internal reflection " << 1.0 - e.value.r << "\n";
      }
    }
  }
}

TEST(Material, IsReciprocalAndConsistent) {
  const MaterialSpec spec{lambert(0.6), ggx(0.25, FresnelMode::exact, 0.0), Combine::layered, 0.0};
  const Material m(spec);
  Pcg32 rng(7);
  for (int k = 0; k < 2000; ++k) {
    const Vec3 a = from_mu(1.0 - rng.uniform(), 6.283 * rng.uniform());
    const Vec3 b = from_mu(1.0 - rng.uniform(), 6.283 * rng.uniform());
    const Rgb fab = m.eval(a, b), fba = m.eval(b, a);
    // The layered form is symmetric in (μi, μo) by construction; only rounding of the products differs.
    EXPECT_NEAR(fab.r, fba.r, 1e-12 * std::max(1.0, fab.r));
    const auto s = m.sample(a, {rng.uniform(), rng.uniform()}, rng.uniform());
    if (!s) continue;
    EXPECT_GT(s->pdf, 0.0);
    EXPECT_DOUBLE_EQ(s->pdf, m.pdf(a, s->wi));
    EXPECT_DOUBLE_EQ(s->f.r, m.eval(a, s->wi).r);
    EXPECT_TRUE(s->weight.is_finite());
  }
}

// A tint (base colour) multiplies the diffuse term only: with Lambert(ρ) as the diffuse lobe, tinting by t must equal
// the untinted material whose Lambert albedo is ρ·t, in both combinations, to rounding (the lobes are evaluated
// by the same code; 1e-12 relative). Sampling with a tint returns the tinted value and the untinted pdf.
TEST(Material, TintScalesTheDiffuseTermOnly) {
  const Rgb tint{0.9, 0.5, 0.1};
  for (Combine combine : {Combine::weights, Combine::layered}) {
    const MaterialSpec base{lambert(0.8), ggx(0.3, FresnelMode::schlick, 0.04), combine, 0.3};
    MaterialSpec tinted_spec = base;
    tinted_spec.diffuse.albedo = Rgb{0.8} * tint;
    const Material m(base), reference(tinted_spec);
    Pcg32 rng(7);
    for (int i = 0; i < 200; ++i) {
      const Vec3 wo = from_mu(0.05 + 0.9 * rng.uniform(), 6.28 * rng.uniform());
      const Vec3 wi = from_mu(0.05 + 0.9 * rng.uniform(), 6.28 * rng.uniform());
      const Rgb a = m.eval(wo, wi, tint), b = reference.eval(wo, wi);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(a[c], b[c], 1e-12 * std::abs(b[c]) + 1e-300);
      const auto s = m.sample(wo, {rng.uniform(), rng.uniform()}, rng.uniform(), tint);
      if (!s) continue;
      const Rgb f = m.eval(wo, s->wi, tint);
      for (int c = 0; c < 3; ++c) EXPECT_DOUBLE_EQ(s->f[c], f[c]);
      EXPECT_DOUBLE_EQ(s->pdf, m.pdf(wo, s->wi));
    }
  }
}

}  // namespace
}  // namespace kiln::brdf
