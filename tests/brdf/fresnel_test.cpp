// Fresnel reflectance against known values of optics: normal incidence, Brewster's angle, total internal reflection,
// grazing incidence, the survey's eq 10–11 written out independently, and Schlick's end points.
#include "bakers/brdf/fresnel.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "bakers/math/constants.h"
#include "tests/support/tolerance.h"

namespace kiln::brdf {
namespace {

using test::close;

// Relative indices on both sides of 1: air→water, air→glass, air→diamond, a weak interface, and their inverses
// (light leaving the denser medium), which have a critical angle.
const std::vector<double> kEtas = {1.01, 1.1, 1.33, 1.5, 2.0, 2.42, 1 / 1.01, 1 / 1.33, 1 / 1.5, 1 / 2.42, 0.5};

// The survey's eq 10–11 (Cook & Torrance 1982), in its own variables, for g² = η² + c² − 1 ≥ 0.
double fresnel_eq10(double c, double eta) {
  const double g = std::sqrt(eta * eta + c * c - 1.0);
  const double a = (g - c) / (g + c);
  const double b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
  return 0.5 * a * a * (1.0 + b * b);
}

TEST(FresnelDielectric, NormalIncidenceIsSquaredIndexRatio) {
  for (double eta : kEtas) {
    const double r = (eta - 1.0) / (eta + 1.0);
    // At c = 1 both polarisations reduce to ±(η−1)/(η+1): a handful of roundings, so agreement to a few ulp
    // (1e-14 relative leaves room for ~50 ulp).
    EXPECT_TRUE(close(fresnel_dielectric(1.0, eta), r * r, 1e-14)) << "eta=" << eta;
    EXPECT_TRUE(close(f0_from_eta(eta), r * r, 1e-15)) << "eta=" << eta;
    const FresnelPolarized p = fresnel_dielectric_polarized(1.0, eta);
    EXPECT_TRUE(close(p.rs, p.rp, 1e-14)) << "at normal incidence s and p are the same wave, eta=" << eta;
  }
  // Published values: air→glass 4 %, air→water 2.0 %, air→diamond 17.2 %.
  EXPECT_NEAR(fresnel_dielectric(1.0, 1.5), 0.04, 1e-15);
  EXPECT_NEAR(fresnel_dielectric(1.0, 1.33), 0.02006, 1e-5);  // 0.33² / 2.33² = 0.0200593...
  EXPECT_NEAR(fresnel_dielectric(1.0, 2.42), 0.1724, 1e-4);   // 1.42² / 3.42² = 0.172395...
  // Reciprocity of the interface at normal incidence: η and 1/η reflect the same.
  EXPECT_TRUE(close(fresnel_dielectric(1.0, 1.5), fresnel_dielectric(1.0, 1 / 1.5), 1e-14));
}

TEST(FresnelDielectric, BrewsterAngleCancelsThePPolarisation) {
  for (double eta : kEtas) {
    // tan θ_B = η, so cos θ_B = 1 / sqrt(1 + η²). For η < 1 Brewster's angle lies before the critical angle
    // (tan θ_B = η < η / sqrt(1 − η²) = tan θ_c), so it exists on both sides of the interface.
    const double c_b = 1.0 / std::sqrt(1.0 + eta * eta);
    const FresnelPolarized p = fresnel_dielectric_polarized(c_b, eta);
    // rp is the square of an amplitude (η c − c_t)/(η c + c_t) whose numerator cancels exactly in real arithmetic;
    // in doubles the numerator is a few ulp of quantities ≤ 1, so rp ≲ (1e-15)² — 1e-26 leaves a wide margin.
    EXPECT_LT(p.rp, 1e-26) << "eta=" << eta;
    // Meanwhile rs keeps its known value ((η² − 1) / (η² + 1))² (c_t = η c at Brewster's angle).
    const double rs = (eta * eta - 1.0) / (eta * eta + 1.0);
    EXPECT_TRUE(close(p.rs, rs * rs, 1e-12)) << "eta=" << eta;  // cancellation in (1 − η²) for η ≈ 1: ~100 ulp
    EXPECT_TRUE(close(fresnel_dielectric(c_b, eta), 0.5 * rs * rs, 1e-12)) << "eta=" << eta;
    // It is a minimum: 0.02 rad away on either side rp is clearly positive (≈ (dθ · d amplitude/dθ)², ≥ 1e-8 here).
    const double theta_b = std::atan(eta);
    for (double d : {-0.02, 0.02}) {
      EXPECT_GT(fresnel_dielectric_polarized(std::cos(theta_b + d), eta).rp, 1e-8) << "eta=" << eta << " d=" << d;
    }
  }
}

TEST(FresnelDielectric, TotalInternalReflectionBeyondTheCriticalAngle) {
  for (double eta : kEtas) {
    if (eta >= 1.0) continue;
    // sin θ_c = η. Past it the reflection is total: F = 1 exactly, both polarisations.
    const double theta_c = std::asin(eta);
    for (double theta = theta_c + 1e-9; theta <= kPiOver2; theta += (kPiOver2 - theta_c) / 37.0) {
      const FresnelPolarized p = fresnel_dielectric_polarized(std::cos(theta), eta);
      EXPECT_EQ(p.rs, 1.0) << "eta=" << eta << " theta=" << theta;
      EXPECT_EQ(p.rp, 1.0) << "eta=" << eta << " theta=" << theta;
      EXPECT_EQ(fresnel_dielectric(std::cos(theta), eta), 1.0) << "eta=" << eta << " theta=" << theta;
    }
    EXPECT_EQ(fresnel_dielectric(0.0, eta), 1.0);
    // Just inside the critical angle part of the light is transmitted: F < 1, and F rises towards 1 as θ → θ_c
    // (continuity of the transition, so no jump in brightness at the critical angle).
    double previous = 0.0;
    for (double d : {1e-2, 1e-3, 1e-4, 1e-6}) {
      const double f = fresnel_dielectric(std::cos(theta_c - d), eta);
      EXPECT_LT(f, 1.0) << "eta=" << eta << " d=" << d;
      EXPECT_GT(f, previous) << "eta=" << eta << " d=" << d;
      previous = f;
    }
    // Near θ_c, 1 − F ∝ sqrt(θ_c − θ) (c_t ∝ sqrt(θ_c − θ)); at 1e-6 rad the gap is of order 1e-3 → F > 0.9.
    EXPECT_GT(previous, 0.9) << "eta=" << eta;
  }
}

TEST(FresnelDielectric, NoInterfaceReflectsNothing) {
  for (int i = 0; i <= 100; ++i) {
    const double c = i / 100.0;
    EXPECT_EQ(fresnel_dielectric(c, 1.0), 0.0) << "c=" << c;
    const FresnelPolarized p = fresnel_dielectric_polarized(c, 1.0);
    EXPECT_EQ(p.rs, 0.0);
    EXPECT_EQ(p.rp, 0.0);
  }
}

TEST(FresnelDielectric, GrazingIncidenceReflectsEverything) {
  for (double eta : kEtas) {
    // c = 0: both amplitudes are exactly −1 for η > 1 (and TIR for η < 1), so F = 1 exactly.
    EXPECT_EQ(fresnel_dielectric(0.0, eta), 1.0) << "eta=" << eta;
    // And continuously so: at c = 1e-6, 1 − F ≈ 4c · (something of order 1) for η > 1.
    EXPECT_GT(fresnel_dielectric(1e-6, eta), 1.0 - 1e-4) << "eta=" << eta;
  }
}

TEST(FresnelDielectric, MatchesTheSurveysEquation10WhereGIsReal) {
  double worst = 0.0;
  for (double eta : kEtas) {
    for (int i = 0; i <= 1000; ++i) {
      const double c = i / 1000.0;
      if (eta * eta + c * c - 1.0 < 0.0) continue;  // g imaginary: total internal reflection, tested above
      if (c == 0.0 && eta == 1.0) continue;
      const double f = fresnel_dielectric(c, eta), ref = fresnel_eq10(c, eta);
      // Both forms round ~20 operations; the subtraction g − c (or c − η c_t) loses up to log10(1/|η − 1|) ≈ 2
      // digits for η = 1.01. 1e-11 relative covers that with a factor ~10 of margin; abs 1e-300 only for 0 = 0.
      EXPECT_TRUE(close(f, ref, 1e-11, 1e-300)) << "c=" << c << " eta=" << eta << " f=" << f << " eq10=" << ref;
      if (ref > 0) worst = std::fmax(worst, std::fabs(f - ref) / ref);
    }
  }
  std::printf("max relative difference to eq 10: %.3g\n", worst);
}

TEST(FresnelDielectric, BoundedAndFiniteForAnyInput) {
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  const double denorm = std::numeric_limits<double>::denorm_min();
  std::vector<double> cosines = {nan,    -inf, -1.0,        -1e-300, -denorm,     0.0, denorm,
                                 1e-300, 1e-8, 1.0 - 1e-16, 1.0,     1.0 + 1e-15, 2.0, inf};
  for (int i = 0; i <= 200; ++i) cosines.push_back(i / 200.0);
  // The index of refraction comes from a validated spec; this sweeps the physically meaningful range and a margin.
  // validate() accepts any η in (0, 10], so the tiny η whose square underflows to 0 (η < 1.5e-154) is included too.
  std::vector<double> etas = kEtas;
  for (double e : {1e-200, 1e-3, 0.1, 0.999999, 1.0, 1.000001, 3.0, 10.0, 1e3}) etas.push_back(e);
  for (double eta : etas) {
    for (double c : cosines) {
      const double f = fresnel_dielectric(c, eta);
      EXPECT_TRUE(std::isfinite(f) && f >= 0.0 && f <= 1.0) << "c=" << c << " eta=" << eta << " F=" << f;
      const FresnelPolarized p = fresnel_dielectric_polarized(c, eta);
      EXPECT_TRUE(std::isfinite(p.rs) && p.rs >= 0.0 && p.rs <= 1.0) << "c=" << c << " eta=" << eta;
      EXPECT_TRUE(std::isfinite(p.rp) && p.rp >= 0.0 && p.rp <= 1.0) << "c=" << c << " eta=" << eta;
      const double s = fresnel_schlick(c, f0_from_eta(eta));
      EXPECT_TRUE(std::isfinite(s) && s >= 0.0 && s <= 1.0) << "c=" << c << " eta=" << eta << " S=" << s;
    }
  }
  // A NaN index of refraction reflects nothing rather than poisoning a texel.
  EXPECT_EQ(fresnel_dielectric(0.5, nan), 0.0);
}

TEST(FresnelSchlick, EndPoints) {
  for (double f0 : {0.0, 0.02, 0.04, 0.5, 0.9, 1.0}) {
    // (1 − c)^5 is exactly 0 at c = 1 and exactly 1 at c = 0, so these hold bit for bit.
    EXPECT_EQ(fresnel_schlick(1.0, f0), f0);
    EXPECT_EQ(fresnel_schlick(0.0, f0), 1.0);
    // Monotone between them: Schlick's weight (1 − c)^5 decreases with c.
    double previous = 2.0;
    for (int i = 0; i <= 100; ++i) {
      const double s = fresnel_schlick(i / 100.0, f0);
      EXPECT_LE(s, previous);
      previous = s;
    }
  }
  // Halfway: (1 − 0.5)^5 = 1/32 exactly in binary.
  EXPECT_EQ(fresnel_schlick(0.5, 0.04), 0.04 + 0.96 / 32.0);
  const Rgb f0(0.04, 0.5, 0.9);
  const Rgb s1 = fresnel_schlick(1.0, f0), s0 = fresnel_schlick(0.0, f0);
  EXPECT_EQ(s1, f0);
  EXPECT_EQ(s0, Rgb(1.0));
}

}  // namespace
}  // namespace kiln::brdf
