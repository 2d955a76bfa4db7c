// The irradiance cubemap by direct convolution with the clamped cosine.
#include "bakers/envmap/irradiance.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "bakers/envmap/sh.h"
#include "bakers/math/constants.h"

namespace kiln::envmap {
namespace {

TEST(Irradiance, ConstantEnvironmentGivesPiTimesL) {
  const Rgb l{0.5, 2.0, 1000.0};
  for (int src : {1, 3, 16}) {
    const Cubemap e = irradiance_cubemap(Cubemap(src, l), 4);
    for (int f = 0; f < kFaceCount; ++f)
      for (const Rgb& t : e.face(f)) {
        // π · Σ L w / Σ w with equal L: a few roundings of a sum of ≤ 1536 positive terms, ≲ 1e-13 relative.
        ASSERT_NEAR(t.r / (kPi * l.r), 1.0, 1e-13);
        ASSERT_NEAR(t.b / (kPi * l.b), 1.0, 1e-13);
      }
  }
}

// The step "1 for y > 0": E(n) = π (1 + sin e) / 2 at elevation e (the sky's horizon cuts the normal's hemisphere
// in a lune). The source is exact for even n (the horizon runs along texel edges); what remains is the quadrature:
// the midpoint rule on each texel, O(h²) with h = 2/n, for the smooth part, and the kink of max(0, n·ω) crossing
// O(n) texels with an O(h³) error each, O(h²) again. So the error is C/n²; see the measured constants below.
TEST(Irradiance, StepEnvironmentMatchesTheAnalyticIrradiance) {
  double previous = 0;
  for (int src : {16, 32, 64}) {
    const Cubemap sky = cubemap_from(src, [](const Vec3& d) { return d.y > 0 ? Rgb{1.0} : Rgb{0.0}; });
    const int out = 8;
    const Cubemap e = irradiance_cubemap(sky, out);
    double worst = 0;
    for (int f = 0; f < kFaceCount; ++f)
      for (int y = 0; y < out; ++y)
        for (int x = 0; x < out; ++x) {
          const Vec3 nrm = texel_direction(f, x, y, out);
          const double analytic = kPi * (1.0 + nrm.y) / 2.0;  // sin e = n_y for a unit normal
          worst = std::fmax(worst, std::fabs(e.at(f, x, y).g - analytic));
        }
    std::printf("source %d: max |E - pi(1 + sin e)/2| = %.3e (%.2f / n^2)\n", src, worst, worst * src * src);
    // The texel midpoint rule on an integrand with |∇²| ≲ 2 (cosine) over a hemisphere of area 2π gives
    // ≲ 2π · h²/24 · 2 ≈ 2/n², the kink adds the same order: held to 4/n² (measured: 0.44/n² at n = 16, 32, 64).
    EXPECT_LT(worst, 4.0 / (src * src)) << "source " << src;
    if (previous > 0) {
      EXPECT_GT(previous / worst, 3.0) << "source " << src;  // second order: ×4 per doubling, accepted from 3
    }
    previous = worst;
  }
}

TEST(Irradiance, AgreesWithTheFunkHeckeIrradianceOfABandLimitedSky) {
  // L = 1 + 0.5 y + 0.3 x z (bands 0–2): E(n) = π + (2π/3) 0.5 n_y + (π/4) 0.3 n_x n_z exactly; and the SH path
  // must agree with the convolution to the sum of both discretisation errors.
  const int src = 32;
  const Cubemap sky = cubemap_from(src, [](const Vec3& d) { return Rgb{1.0 + 0.5 * d.y + 0.3 * d.x * d.z}; });
  const int out = 6;
  const Cubemap e = irradiance_cubemap(sky, out);
  const ShCoefficients sh = sh_radiance_to_irradiance(project_sh(sky));
  for (int f = 0; f < kFaceCount; ++f)
    for (int y = 0; y < out; ++y)
      for (int x = 0; x < out; ++x) {
        const Vec3 nrm = texel_direction(f, x, y, out);
        const double analytic = kPi + (2.0 * kPi / 3.0) * 0.5 * nrm.y + (kPi / 4.0) * 0.3 * nrm.x * nrm.z;
        // The same O(1/n²) quadrature bound as the step (4/n²), the radiance here being at most 1.8.
        EXPECT_NEAR(e.at(f, x, y).r, analytic, 8.0 / (src * src));
        EXPECT_NEAR(evaluate_sh(sh, nrm).r, e.at(f, x, y).r, 8.0 / (src * src) + 5.0 / (src * src));
      }
}

TEST(Irradiance, CubemapTexelsAreTheConvolutionAtTheirCentres) {
  const Cubemap sky = cubemap_from(6, [](const Vec3& d) { return Rgb{std::exp(3.0 * d.x), 1.0 + d.z * d.z, 0.0}; });
  const Cubemap e = irradiance_cubemap(sky, 3);
  for (int f = 0; f < kFaceCount; ++f)
    for (int y = 0; y < 3; ++y)
      for (int x = 0; x < 3; ++x) {
        // irradiance_at normalises its normal again, which may move it by an ulp: 1e-14 relative.
        const Rgb ref = irradiance_at(sky, texel_direction(f, x, y, 3));
        EXPECT_NEAR(e.at(f, x, y).r, ref.r, 1e-14 * ref.r);
        EXPECT_NEAR(e.at(f, x, y).g, ref.g, 1e-14 * ref.g);
      }
  // Singular input: the zero normal has no hemisphere and gives black; bad sizes are rejected.
  EXPECT_EQ(irradiance_at(sky, {0, 0, 0}), Rgb{});
  EXPECT_THROW(irradiance_cubemap(sky, 0), std::invalid_argument);
}

}  // namespace
}  // namespace kiln::envmap
