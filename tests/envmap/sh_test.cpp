// Order-2 spherical harmonics of cubemaps: projection with exact solid angles, the cosine lobe, irradiance E(n).
#include "bakers/envmap/sh.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "bakers/math/constants.h"
#include "bakers/math/rng.h"

namespace kiln::envmap {
namespace {

Vec3 random_unit(Pcg32& rng) {
  const double z = 1.0 - 2.0 * rng.uniform(), phi = 2.0 * kPi * rng.uniform();
  const double r = std::sqrt(std::fmax(0.0, 1.0 - z * z));
  return {r * std::cos(phi), r * std::sin(phi), z};
}

// 1 above the horizon (y > 0), 0 below. For even n the horizon runs along texel edges of the side faces, so no texel
// straddles it and the cube represents the step exactly.
Cubemap step_cube(int n) {
  return cubemap_from(n, [](const Vec3& d) { return d.y > 0 ? Rgb{1.0} : Rgb{0.0}; });
}

TEST(Sh, BasisConstantsMatchTheirPublishedValues) {
  // R&H 2001 eq. 3 / Sloan's "Stupid SH tricks" table, to the 6 digits printed there.
  const ShBasis b = sh_basis({0, 0, 1});
  EXPECT_NEAR(b[0], 0.282095, 5e-7);
  EXPECT_NEAR(b[2], 0.488603, 5e-7);
  EXPECT_NEAR(b[6], 0.315392 * 2.0, 1e-6);
  const double s = 1.0 / std::sqrt(2.0);
  EXPECT_NEAR(sh_basis({s, s, 0})[4], 1.092548 * 0.5, 5e-7);
  EXPECT_NEAR(sh_basis({1, 0, 0})[8], 0.546274, 5e-7);
  EXPECT_DOUBLE_EQ(sh_cosine_lobe(0), kPi);
  EXPECT_DOUBLE_EQ(sh_cosine_lobe(1), 2.0 * kPi / 3.0);
  EXPECT_DOUBLE_EQ(sh_cosine_lobe(2), kPi / 4.0);
}

TEST(Sh, ConstantEnvironmentGivesPiTimesL) {
  const Rgb l{0.5, 2.0, 1000.0};
  for (int n : {1, 2, 5, 16}) {
    const ShCoefficients c = project_sh(Cubemap(n, l));
    // L_00 = L · Y00 · Σ ΔΩ = L · 2√π; the other sums vanish by the cube's symmetries (x → −x etc. for the odd
    // terms, permutation of the axes for 3z² − 1 and x² − y²), leaving only rounding.
    EXPECT_NEAR(c[0].b / (l.b * 2.0 * std::sqrt(kPi)), 1.0, 1e-13);
    for (int i = 1; i < kShCount; ++i) EXPECT_NEAR(c[i].b / l.b, 0.0, 1e-13) << "coefficient " << i;
    const ShCoefficients e = sh_radiance_to_irradiance(c);
    Pcg32 rng(n);
    for (int k = 0; k < 1000; ++k) {
      const Rgb got = evaluate_sh(e, random_unit(rng));
      ASSERT_NEAR(got.r / (kPi * l.r), 1.0, 1e-13);
      ASSERT_NEAR(got.b / (kPi * l.b), 1.0, 1e-13);
    }
  }
}

// The step "1 for y > 0": its exact coefficients are L_00 = Y00 · 2π = √π and L_1-1 (the y term) = √(3/4π) ∫_{y>0} y
// dω = √(3/4π) · π = √(3π)/2; every other band-2 coefficient is 0 (the xy, yz, xz terms are odd in x or z; for the
// zonal term about y, ∫₀¹ P₂(μ) dμ = 0). So the order-2 irradiance is
//     E₂(n) = π · √π · Y00 + (2π/3) · (√(3π)/2) · √(3/4π) n_y = π/2 + (π/2) n_y = π (1 + sin e) / 2,
// and the truncation error of order 2 is exactly zero here: beyond band 1 the step has only odd bands (∫₀¹ P_l = 0
// for even l ≥ 2) and the clamped cosine only even ones (Â_l = 0 for odd l ≥ 3), so their product vanishes for every
// l ≥ 2. What remains is the cube's discretisation: the midpoint rule per texel, O(1/n²).
TEST(Sh, StepEnvironmentMatchesItsAnalyticProjection) {
  const double exact[kShCount] = {std::sqrt(kPi), std::sqrt(3.0 * kPi) / 2.0, 0, 0, 0, 0, 0, 0, 0};
  double previous_error = 0;
  for (int n : {16, 32, 64}) {
    const ShCoefficients c = project_sh(step_cube(n));
    double coeff_error = 0;
    for (int i = 0; i < kShCount; ++i) coeff_error = std::fmax(coeff_error, std::fabs(c[i].g - exact[i]));
    // L_00 sums whole texels above the horizon: exactly 2π · Y00 up to rounding.
    EXPECT_NEAR(c[0].g, exact[0], 1e-13);
    const ShCoefficients e = sh_radiance_to_irradiance(c);
    double e_error = 0;
    for (int k = 0; k <= 90; ++k) {
      const double elev = kPi * (k / 90.0 - 0.5);
      for (double az : {0.0, 1.0, 2.5}) {
        const Vec3 nrm{std::cos(elev) * std::cos(az), std::sin(elev), std::cos(elev) * std::sin(az)};
        const double analytic = kPi * (1.0 + std::sin(elev)) / 2.0;
        e_error = std::fmax(e_error, std::fabs(evaluate_sh(e, nrm).g - analytic));
      }
    }
    std::printf("n = %d: max coefficient error %.3e, max |E - pi(1 + sin e)/2| %.3e\n", n, coeff_error, e_error);
    // Midpoint rule: the smooth integrand y · Y_i over a texel of width h = 2/n deviates by ~h²/24 · |∇²|; summed
    // over the hemisphere (area 2π) that is ≲ 2π · (2/n)² / 24 · 6 ≈ 6/n². Held to 2/n² for the coefficients (the
    // measured constant is ~0.5) and, through Â ≤ π and |Y| ≤ 1.1 summed over 9 terms, 10/n² for E.
    EXPECT_LT(coeff_error, 2.0 / (n * n)) << "size " << n;
    EXPECT_LT(e_error, 10.0 / (n * n)) << "size " << n;
    // And the error is the discretisation's: it falls as 1/n² (ratio 4 per doubling, accepted down to 3).
    if (previous_error > 0) {
      EXPECT_GT(previous_error / e_error, 3.0) << "size " << n;
    }
    previous_error = e_error;
  }
}

TEST(Sh, BasisFunctionsProjectToUnitVectors) {
  // Orthonormality under the exact solid angles: projecting the cube of Y_j gives e_j, up to the midpoint rule's
  // O(1/n²) error (products Y_i Y_j are polynomials of degree ≤ 4 with |∇²| ≲ 20 · 0.3, over 4π). Measured:
  // 0.40/n² at n = 16, 32, 64; held to 2/n².
  for (int n : {16, 32, 64}) {
    double worst = 0;
    for (int j = 0; j < kShCount; ++j) {
      const ShCoefficients c = project_sh(cubemap_from(n, [j](const Vec3& d) { return Rgb{sh_basis(d)[j]}; }));
      for (int i = 0; i < kShCount; ++i) worst = std::fmax(worst, std::fabs(c[i].r - (i == j ? 1.0 : 0.0)));
    }
    std::printf("n = %d: max |<Y_i, Y_j> - delta_ij| = %.3e\n", n, worst);
    EXPECT_LT(worst, 2.0 / (n * n)) << "size " << n;
  }
}

TEST(Sh, BandLimitedEnvironmentGivesTheFunkHeckeIrradiance) {
  // L = 1 + 0.5 y + 0.3 x z is in bands 0–2, so E(n) = π · 1 + (2π/3) · 0.5 n_y + (π/4) · 0.3 n_x n_z exactly
  // (Funk–Hecke), an analytic reference independent of the basis constants.
  const int n = 64;
  const ShCoefficients e = sh_radiance_to_irradiance(
      project_sh(cubemap_from(n, [](const Vec3& d) { return Rgb{1.0 + 0.5 * d.y + 0.3 * d.x * d.z}; })));
  Pcg32 rng(3);
  for (int k = 0; k < 1000; ++k) {
    const Vec3 nrm = random_unit(rng);
    const double analytic = kPi + (2.0 * kPi / 3.0) * 0.5 * nrm.y + (kPi / 4.0) * 0.3 * nrm.x * nrm.z;
    // Orthonormality holds to ~0.5/n² (test above); with Â ≤ π and three terms, 5/n² bounds the error.
    ASSERT_NEAR(evaluate_sh(e, nrm).r, analytic, 5.0 / (n * n));
  }
}

}  // namespace
}  // namespace kiln::envmap
