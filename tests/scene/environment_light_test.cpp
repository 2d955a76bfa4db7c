// The environment light: irradiance from constant and image environments against closed forms (E = π under radiance
// 1; π(1 + sin e)/2 under a sky of 1 over a black ground) and against a quadrature of the bilinear image (a 1-texel
// hot spot); importance sampling against pdf_li by χ² with rotation; the rotation convention of env_input.h.
#include "bakers/scene/environment_light.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "bakers/envmap/env_input.h"
#include "tests/scene/light_test_util.h"
#include "tests/support/tolerance.h"

namespace kiln::scene {
namespace {

constexpr double kDeg = kPi / 180.0;

Environment image_env(int w, int h, const std::function<Rgb(int, int)>& texel, double rotation = 0) {
  Environment env;
  env.width = w;
  env.height = h;
  env.rotation_degrees = rotation;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) env.equirect.push_back(texel(x, y));
  return env;
}

TEST(EnvironmentLight, ConstantRadianceGivesPi) {
  Environment env;
  env.constant = Rgb{1, 0.5, 0.25};
  const EnvironmentLight light(env);
  EXPECT_FALSE(light.importance_sampled());
  // Cosine sampling under constant radiance: every sample is exactly L π (zero variance), so the mean is π to
  // rounding for any normal.
  for (const Vec3& n : {Vec3{0, 1, 0}, normalize(Vec3{1, -2, 0.5})}) {
    const auto e = test::estimate_irradiance(light, {}, n, 1000, 3);
    EXPECT_TRUE(test::close(e.mean, kPi, 1e-12)) << e.mean;
    EXPECT_LT(e.standard_error, 1e-12);
  }
  EXPECT_TRUE(test::close(light.integral().g, 0.5 * 4 * kPi, 1e-15));
  EXPECT_TRUE(test::close(light.power(2).r, 4 * kPi * kPi * 4, 1e-15));
  // No surface (n = 0): uniform over the sphere.
  const auto s = light.sample_li({}, {}, {0.3, 0.6});
  ASSERT_TRUE(s);
  EXPECT_DOUBLE_EQ(s->pdf, kInv4Pi);
  EXPECT_TRUE(std::isinf(s->distance));
}

TEST(EnvironmentLight, ConstantImageWithImportanceMapGivesPi) {
  const EnvironmentLight light(image_env(64, 32, [](int, int) { return Rgb{1}; }));
  ASSERT_TRUE(light.importance_sampled());
  // The image's integral: its per-row solid angles sum to 4π (rounding only).
  EXPECT_TRUE(test::close(light.integral().r, 4 * kPi, 1e-13));
  for (const Vec3& n : {Vec3{0, 1, 0}, normalize(Vec3{0.3, -0.2, 1})}) {
    const auto e = test::estimate_irradiance(light, {}, n, 200000, 5);
    ASSERT_TRUE(e.all_finite);
    // Bilinear interpolation of a constant is that constant: no discretisation; 5 standard errors.
    EXPECT_NEAR(e.mean, kPi, 5 * e.standard_error) << "standard error " << e.standard_error;
  }
}

TEST(EnvironmentLight, SkyOverBlackGroundGivesHalfOnePlusSinElevation) {
  // 256 × 128: rows 0..63 are the sky (θ < 90°), 64..127 the ground. The bilinear lookup blurs the horizon over
  // ±δ = ±π/(2·128) in elevation with a ramp that is odd about the horizon, so its error against the step is
  // second order: |ΔE| ≤ ∫ |ΔL(x)| |g'(0) x| dx with g the azimuthal integral of max(0, n·ω), |g'| ≤ 2π, giving
  // |ΔE| ≤ π δ²/3 ≈ 1.6e-4 (added to 5 standard errors).
  const int w = 256, h = 128;
  const double delta = kPi / (2 * h);
  const EnvironmentLight light(image_env(w, h, [&](int, int y) { return Rgb{y < h / 2 ? 1.0 : 0.0}; }));
  uint64_t seed = 10;
  for (double e_deg : {90.0, 30.0, 0.0, -45.0}) {
    const double e = e_deg * kDeg;
    const Vec3 n{std::cos(e), std::sin(e), 0};
    const auto est = test::estimate_irradiance(light, {}, n, 200000, ++seed);
    ASSERT_TRUE(est.all_finite);
    const double exact = kPi * (1 + std::sin(e)) / 2;
    EXPECT_NEAR(est.mean, exact, 5 * est.standard_error + kPi * delta * delta / 3)
        << "elevation " << e_deg << "°, standard error " << est.standard_error;
  }
}

TEST(EnvironmentLight, SamplingMatchesPdfLiWithRotation) {
  // A small image with structure at every scale (so that pixel boundaries cut across the χ² cells), a bright texel
  // and black rows, rotated by 37°: sample_li against pdf_li over the whole sphere.
  Pcg32 gen(9);
  const EnvironmentLight light(image_env(
      32, 16,
      [&](int x, int y) {
        if (y == 12) return Rgb{0};
        if (x == 5 && y == 3) return Rgb{500, 300, 100};
        return Rgb{gen.uniform() * (1 + x % 4), gen.uniform(), gen.uniform() * 0.1};
      },
      37.0));
  test::DirectionChi2Options o;
  o.axis = {0, 1, 0};
  o.theta_max = kPi;
  o.n_theta = 32;
  o.n_phi = 64;
  o.samples = 300000;
  o.max_depth = 7;
  o.presplit = 2;
  o.test_count = 2;
  const auto r = test::direction_chi2(
      test::light_sampler_at(light, {}, {0, 1, 0}),
      [&](const Vec3& w) {
        return light.pdf_li({}, {0, 1, 0}, w, {});
      },
      o);
  EXPECT_TRUE(r.passed) << r.details;
  // Over the whole sphere the density integrates to 1 (quadrature of the pixel outlines: ~1e-5, allowed 1e-4).
  EXPECT_NEAR(r.pdf_integral, 1.0, 1e-4) << r.details;
}

// ∫ L_bilinear(ω) cos θ dω over the upper hemisphere (n = +Y) of an unrotated image, by Gauss–Legendre on the
// pieces between pixel centres (where the bilinear interpolant is smooth in (θ, φ)), with θ = 90° as a breakpoint.
double upper_irradiance_by_quadrature(const EnvironmentLight& light, int w, int h) {
  std::vector<double> tb = {0.0, kPi / 2}, pb = {0.0, 2 * kPi};
  for (int y = 0; y < h; ++y)
    if (kPi * (y + 0.5) / h < kPi / 2) tb.push_back(kPi * (y + 0.5) / h);
  for (int x = 0; x < w; ++x) pb.push_back(2 * kPi * (x + 0.5) / w);
  const test::DirectionRule rule = test::direction_rule(tb, pb, 1, 6);
  // The rule's (θ, φ) are read as the image's (πv, 2πu): the weights sin θ dθ dφ are the solid angle either way.
  return test::integrate(rule, [&](const Vec3& w_rule) {
    const double theta = test::spherical_theta(w_rule), phi = test::spherical_phi(w_rule);
    if (theta > kPi / 2) return 0.0;
    const Vec3 d = envmap::equirect_uv_to_direction(phi / (2 * kPi), theta / kPi);
    return light.radiance(d).r * d.y;
  });
}

TEST(EnvironmentLight, OneTexelHotSpotStaysFiniteAndUnbiased) {
  // A 1e6 texel in a dim 0.01 sky: the importance map must find it (or the estimate would be hopeless) and nothing
  // may overflow.
  const int w = 64, h = 32;
  const EnvironmentLight light(
      image_env(w, h, [](int x, int y) { return (x == 20 && y == 9) ? Rgb{1e6} : Rgb{0.01}; }));
  const double exact = upper_irradiance_by_quadrature(light, w, h);
  const auto e = test::estimate_irradiance(light, {}, {0, 1, 0}, 200000, 31);
  ASSERT_TRUE(e.all_finite);
  // 5 standard errors; the reference integrates a piecewise-smooth function exactly to ~1e-12 (order-6 rule on the
  // smooth pieces).
  EXPECT_NEAR(e.mean, exact, 5 * e.standard_error + 1e-9 * exact) << "standard error " << e.standard_error;
  // Importance sampling resolves the hot spot: the relative standard error with 200k samples is small (uniform
  // sampling would give ~0.2 here: 1 hit in ~4000 samples carries nearly all the energy).
  EXPECT_LT(e.standard_error / e.mean, 0.01);
  // And the density is consistent at the hot spot (χ² in cells around it).
  test::DirectionChi2Options o;
  o.axis = envmap::equirect_uv_to_direction((20 + 0.5) / w, (9 + 0.5) / h);
  o.theta_max = 0.25;
  o.n_theta = 16;
  o.n_phi = 32;
  o.samples = 200000;
  o.test_count = 2;
  const auto r = test::direction_chi2(
      test::light_sampler_at(light, {}, {0, 1, 0}),
      [&](const Vec3& w) {
        return light.pdf_li({}, {0, 1, 0}, w, {});
      },
      o);
  EXPECT_TRUE(r.passed) << r.details;
}

TEST(EnvironmentLight, RotationFollowsEnvInput) {
  // Le must be what the environment baker sees: envmap::sample_environment on the same image and rotation. A NaN
  // angle (decode_environment refuses it; a hand-built scene may carry it) is no rotation for both, never a NaN.
  Pcg32 gen(4);
  for (double rotation : {0.0, 37.0, -200.0, 725.5, std::numeric_limits<double>::quiet_NaN()}) {
    const Environment env = image_env(
        16, 8,
        [&](int, int) {
          return Rgb{gen.uniform(), gen.uniform(), 0};
        },
        rotation);
    const EnvironmentLight light(env);
    envmap::EnvironmentInput input;
    input.image = envmap::RgbImage(16, 8);
    input.image.pixels = env.equirect;
    input.rotation_degrees = rotation;
    Pcg32 rng(8);
    for (int k = 0; k < 200; ++k) {
      const Vec3 d = sample_uniform_sphere({rng.uniform(), rng.uniform()});
      const Rgb a = light.radiance(d), b = envmap::sample_environment(input, d);
      // The same bilinear lookup of the same rotated direction: equal to rounding of the rotation.
      EXPECT_NEAR(a.r, b.r, 1e-12) << rotation;
      EXPECT_NEAR(a.g, b.g, 1e-12) << rotation;
      const Vec3 back = light.to_world(light.to_image(d));
      EXPECT_NEAR(length(back - d), 0.0, 1e-15);
    }
  }
}

TEST(EnvironmentLight, DegenerateEnvironmentsStayFinite) {
  // Black image: no samples, density 0, no power; NaN and negative texels read as 0.
  const EnvironmentLight black(image_env(8, 4, [](int, int) { return Rgb{0}; }));
  EXPECT_FALSE(black.sample_li({}, {0, 1, 0}, {0.5, 0.5}));
  EXPECT_EQ(black.pdf_li({}, {0, 1, 0}, {0, 1, 0}, {}), 0.0);
  EXPECT_TRUE(black.power(1).is_black());
  // Column 0: a negative channel (read as 0, the rest kept); column 1: a NaN channel (the texel reads as 0, as the
  // decoder replaces it); the rest negative.
  const EnvironmentLight bad(image_env(8, 4, [](int x, int) {
    return x == 0 ? Rgb{0.5, -1, 1} : (x == 1 ? Rgb{std::nan(""), 7, 7} : Rgb{-5, 0, 0});
  }));
  Pcg32 rng(2);
  for (int k = 0; k < 1000; ++k) {
    const auto s = bad.sample_li({}, {0, 1, 0}, {rng.uniform(), rng.uniform()});
    ASSERT_TRUE(s);
    ASSERT_TRUE(s->Li.is_finite() && s->Li.min() >= 0 && std::isfinite(s->pdf) && s->pdf > 0);
    ASSERT_LE(s->Li.g, 0.0);  // no green anywhere: the NaN texel's 7 was dropped with it
  }
  // The poles have no solid angle: density 0 there, never NaN.
  EXPECT_EQ(bad.pdf_li({}, {0, 1, 0}, {0, 1, 0}, {}), 0.0);
  EXPECT_EQ(bad.pdf_li({}, {0, 1, 0}, {0, -1, 0}, {}), 0.0);
  // A size that does not match the texels: a clear error.
  Environment wrong;
  wrong.width = 4;
  wrong.height = 2;
  wrong.equirect.resize(7);
  EXPECT_THROW(EnvironmentLight{wrong}, std::invalid_argument);
  // Black constant: nothing.
  Environment zero;
  zero.constant = Rgb{0};
  EXPECT_FALSE(EnvironmentLight(zero).sample_li({}, {0, 1, 0}, {0.5, 0.5}));
}

}  // namespace
}  // namespace kiln::scene
