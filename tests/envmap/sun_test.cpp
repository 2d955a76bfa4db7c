// The sun as an explicit light (sun.h): the split is exact, the rule finds a tiny bright region and nothing in
// ordinary skies, and sky + sun through the prefilter, irradiance and SH equals the brute-force treatment of the
// whole map.
#include "bakers/envmap/sun.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "bakers/envmap/irradiance.h"
#include "bakers/envmap/prefilter.h"
#include "bakers/math/constants.h"

namespace kiln::envmap {
namespace {

// A smooth sky (strictly positive, different per channel) and the same sky with one texel 10^4 times brighter.
Rgb sky_fn(const Vec3& d) { return {1.0 + 0.5 * d.x + 0.3 * d.y * d.y, 0.8 + 0.4 * d.y, 1.0 + 0.3 * d.z}; }
constexpr int kSunFace = 2, kSunX = 9, kSunY = 5;  // on +Y, off the axes
Cubemap sunny(int n, double factor = 1e4) {
  Cubemap c = cubemap_from(n, &sky_fn);
  c.at(kSunFace, kSunX, kSunY) = c.at(kSunFace, kSunX, kSunY) * factor;
  return c;
}

// The relative RMS error as the bake defines and reports it (prefilter.h).
double rel_rms(const Cubemap& a, const Cubemap& ref) { return relative_rms_error(a, ref); }

TEST(Sun, SplitIsExactAndFindsTheSun) {
  const Cubemap src = sunny(16);
  const SunSplit s = split_sun(src);
  ASSERT_TRUE(s.enabled) << s.reason;
  ASSERT_EQ(s.sun.size(), 1u);
  EXPECT_EQ(s.sun[0].face, kSunFace);
  EXPECT_EQ(s.sun[0].x, kSunX);
  EXPECT_EQ(s.sun[0].y, kSunY);
  // One texel of 6·256 at 10^4 times the sky holds ≈ 10^4/(10^4 + 1536) of the power (the sky's radiance varies
  // ±50 % and texel solid angles ±2.6× over the cube, hence the wide bracket).
  EXPECT_GT(s.power_fraction, 0.7);
  EXPECT_LT(s.power_fraction, 0.95);
  // sky + sun = source: deposit_sun restores every texel (1e-12 relative: two roundings of Ω/Ω = 1).
  Cubemap back = s.sky;
  deposit_sun(back, s.sun);
  for (int f = 0; f < kFaceCount; ++f)
    for (size_t i = 0; i < back.face(f).size(); ++i)
      for (double c : {back.face(f)[i].r - src.face(f)[i].r, back.face(f)[i].g - src.face(f)[i].g})
        EXPECT_NEAR(c, 0.0, 1e-12 * src.face(f)[i].average());
  // The filled sky is the mean of the neighbours: within the sky's range (no hole, no spike).
  const Rgb filled = s.sky.at(kSunFace, kSunX, kSunY);
  EXPECT_GT(filled.g, 0.39);  // sky_fn's green is 0.8 + 0.4 y ∈ [0.4, 1.2]
  EXPECT_LT(filled.g, 1.21);
}

TEST(Sun, OrdinarySkiesHaveNoSunAndForcingIsRecorded) {
  const SunSplit constant = split_sun(Cubemap(8, Rgb{2.0}));
  EXPECT_FALSE(constant.enabled);
  EXPECT_TRUE(constant.sun.empty());
  // 1 above the horizon and 0 below: the 90th percentile is 1, nothing exceeds 32.
  const Cubemap half = cubemap_from(8, [](const Vec3& d) { return d.y > 0 ? Rgb{1.0} : Rgb{0.0}; });
  EXPECT_FALSE(split_sun(half).enabled);
  const SunSplit forced = split_sun(half, SunMode::forced_on);
  EXPECT_FALSE(forced.enabled);
  EXPECT_NE(forced.reason.find("no-op"), std::string::npos) << forced.reason;
  const SunSplit off = split_sun(sunny(16), SunMode::forced_off);
  EXPECT_FALSE(off.enabled);
  EXPECT_NE(off.reason.find("forced off"), std::string::npos) << off.reason;
  EXPECT_EQ(off.sky.face(kSunFace), sunny(16).face(kSunFace));  // the map untouched
}

// A sun of zero power is no sun: the chain with a zero-radiance sun texel is bit-identical to the chain without.
TEST(Sun, ZeroPowerSunIsNoSun) {
  const Cubemap sky = cubemap_from(16, &sky_fn);
  SunTexel zero;
  zero.dir = texel_direction(kSunFace, kSunX, kSunY, 16);
  zero.solid_angle = texel_solid_angle(kSunX, kSunY, 16);
  const auto with = prefilter_specular(sky, std::vector<SunTexel>{zero}, 16, {4, 64});
  const auto without = prefilter_specular(sky, 16, {4, 64});
  for (size_t k = 0; k < with.size(); ++k)
    for (int f = 0; f < kFaceCount; ++f) EXPECT_EQ(with[k].cube.face(f), without[k].cube.face(f)) << k;
}

// Sky + sun against brute force of the whole map, every lobe: 32² source, a 16² chain of 4 levels (ρ = 1/3, 2/3, 1).
// Tolerance 3 % relative RMS per level at N = 256: the sun part is exact up to the difference between the continuous
// W and brute force's discrete Σ D (n·l) Ω (≤ 0.5 % at ρ = 1/3, where the lobe spans ~4 source texels); the sky part
// has the N = 256 error of a smooth map (≤ 1 %, prefilter_test). With the sun left in the map (forced off) the same
// N gives errors several times larger, and they fall as N grows (it converges, just noisier).
// The outlier check: each texel's ratio to the median of its 8 neighbours (across edges) may exceed the reference's
// own ratio there by at most 5 % — a firefly or blotch would be a factor of 10 or more at 10^4 contrast.
TEST(Sun, SkyPlusSunMatchesBruteForceWithoutOutliers) {
  const Cubemap src = sunny(32);
  const SunSplit split = split_sun(src);
  ASSERT_TRUE(split.enabled);
  SunSplit off = split_sun(src, SunMode::forced_off);
  for (auto d : {brdf::Distribution::ggx, brdf::Distribution::beckmann, brdf::Distribution::schlick_beckmann}) {
    PrefilterOptions o{4, 256};
    o.distribution = d;
    const auto chain = prefilter_specular(split.sky, split.sun, 16, o);
    const auto noisy = prefilter_specular(off.sky, 16, o);
    o.samples = 4096;
    const auto noisy_fine = prefilter_specular(off.sky, 16, o);
    for (size_t k = 1; k < chain.size(); ++k) {
      const Cubemap ref = brute_force_prefilter(src, chain[k].cube.size(), chain[k].roughness, d);
      const double e = rel_rms(chain[k].cube, ref), e_off = rel_rms(noisy[k].cube, ref),
                   e_off_fine = rel_rms(noisy_fine[k].cube, ref);
      double worst = 0;
      const Cubemap& out = chain[k].cube;
      auto median = [](const Cubemap& c, int f, int x, int y) {
        std::vector<double> v;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx)
            if (dx || dy) v.push_back(c.texel_extended(f, x + dx, y + dy).average());
        std::nth_element(v.begin(), v.begin() + 4, v.end());
        return v[4];
      };
      for (int f = 0; f < kFaceCount; ++f)
        for (int y = 0; y < out.size(); ++y)
          for (int x = 0; x < out.size(); ++x)
            worst = std::max(worst, (out.at(f, x, y).average() / median(out, f, x, y)) /
                                        (ref.at(f, x, y).average() / median(ref, f, x, y)));
      std::printf("%s level %zu: sun %.2e (est %.2e) | sun off N=256 %.2e N=4096 %.2e | outlier %.3f\n",
                  brdf::to_string(d).c_str(), k, e, chain[k].error_estimate, e_off, e_off_fine, worst);
      EXPECT_LT(e, 0.03) << k;
      EXPECT_LT(worst, 1.05) << k;
      EXPECT_GT(e_off, e) << k;
      EXPECT_LT(e_off_fine, e_off) << k;
    }
  }
}

// The diffuse outputs include the sun exactly: the irradiance cube equals irradiance_at of the whole map (the 32²
// source is not downsampled here) up to the rescaling of the cosine weights, which irradiance_cubemap applies to the
// sky only: |π/Σ w − 1| ≤ 1e-3 at 32² (the midpoint rule's O(1/N²)), times the sun's share ≤ 1; tolerance 2e-3. The
// SH coefficients equal project_sh of the whole map to rounding (1e-12 relative to the constant term).
TEST(Sun, IrradianceAndShIncludeTheSunExactly) {
  const Cubemap src = sunny(32);
  const SunSplit split = split_sun(src);
  const Cubemap irr = irradiance_with_sun(split.sky, split.sun, 4, 32);
  for (int f = 0; f < kFaceCount; ++f)
    for (int y = 0; y < 4; ++y)
      for (int x = 0; x < 4; ++x) {
        const Rgb ref = irradiance_at(src, texel_direction(f, x, y, 4));
        EXPECT_NEAR(irr.at(f, x, y).g, ref.g, 2e-3 * ref.g) << f << " " << x << " " << y;
      }
  const ShCoefficients a = project_sh_with_sun(split.sky, split.sun), b = project_sh(src);
  for (int i = 0; i < kShCount; ++i) EXPECT_NEAR(a[i].g, b[i].g, 1e-12 * b[0].g) << i;
}

}  // namespace
}  // namespace kiln::envmap
