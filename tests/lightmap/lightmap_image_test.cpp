// Per-texel accumulation: means and standard errors (from the replicas' spread) against hand-computed statistics,
// refusal of values that must never reach a texel, and the three EXR files decoded back (pixels bit for bit, metadata
// present).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "bakers/image/exr.h"
#include "bakers/lightmap/lightmap_image.h"

namespace kiln::lightmap {
namespace {

// 2×2 lightmap: texels 0, 1, 3 valid, 2 invalid.
LightmapImage small() { return LightmapImage("wall", 2, 2, {1, 1, 0, 1}); }

constexpr int K = kReplicas;

// One estimate per replica: the replica means are the estimates themselves, and the replica formula
// Σ (m_r − μ)² / (K (K − 1)) is the textbook standard error s/√K with s² the sample variance.
TEST(LightmapImage, OneEstimatePerReplicaGivesTheTextbookStandardError) {
  LightmapImage lm = small();
  // Grey estimates 1..K (luminance = the grey value: the Rec. 709 weights sum to 1): mean (K + 1)/2, sample variance
  // K (K + 1)/12, standard error √((K + 1)/12).
  for (int v = 1; v <= K; ++v) ASSERT_TRUE(lm.add(0, Rgb(v)));
  EXPECT_EQ(lm.count(0), static_cast<uint32_t>(K));
  const double mean = (K + 1) / 2.0, se = std::sqrt((K + 1) / 12.0);
  // A few dozen double operations: 1e-12 relative is far above their rounding, far below any formula error.
  EXPECT_NEAR(lm.mean(0).r, mean, 1e-12);
  EXPECT_NEAR(lm.standard_error(0), se, 1e-12);
  EXPECT_NEAR(lm.relative_error(0), se / mean, 1e-12);
  // The floor only matters above the mean.
  EXPECT_NEAR(lm.relative_error(0, 1.0), se / mean, 1e-12);
  EXPECT_NEAR(lm.relative_error(0, 10.0), se / 10.0, 1e-12);
  // The lightmap metric divides by the brightness it is given instead, with the same floor.
  EXPECT_NEAR(lm.error(0, ErrorMetric::lightmap, 20.0), se / 20.0, 1e-12);
  EXPECT_NEAR(lm.error(0, ErrorMetric::lightmap, 20.0, 40.0), se / 40.0, 1e-12);
  EXPECT_NEAR(lm.brightness(), mean, 1e-12);  // the only texel with estimates

  // Coloured estimates, red and green replica by replica: the error is that of the luminance
  // Y = 0.2126 R + 0.7152 G + 0.0722 B, Σ (m_r − μ)² = K ((y1 − y2)/2)².
  for (int r = 0; r < K; ++r) ASSERT_TRUE(lm.add(1, r % 2 ? Rgb(0, 1, 0) : Rgb(1, 0, 0)));
  const double y1 = 0.2126, y2 = 0.7152;
  EXPECT_NEAR(lm.standard_error(1), (y2 - y1) / 2 / std::sqrt(K - 1.0), 1e-12);
  EXPECT_NEAR(lm.mean(1).g, 0.5, 1e-15);

  // Identical estimates: no spread, error 0 (not a negative variance's NaN).
  for (int r = 0; r < K; ++r) ASSERT_TRUE(lm.add(3, Rgb(0.1, 0.2, 0.3)));
  EXPECT_LT(lm.relative_error(3), 1e-7);
  EXPECT_GE(lm.relative_error(3), 0.0);
}

// Several estimates per replica: only the spread of the replica means counts (estimates within a replica are
// stratified, not independent), and unequal counts weigh each replica by its share.
TEST(LightmapImage, TheErrorComesFromTheSpreadOfTheReplicaMeans) {
  LightmapImage lm = small();
  // Estimate e is in replica e mod K with value (e mod K) + 1 + 10·⌊e/K⌋: replica r holds r + 1 and r + 11, mean
  // r + 6. The replica means spread like 1..K (standard error √((K + 1)/12)); the estimates themselves spread far
  // more (an independent-sample formula would say ~5 times as much).
  for (int e = 0; e < 2 * K; ++e) ASSERT_TRUE(lm.add(0, Rgb((e % K) + 1 + 10.0 * (e / K))));
  EXPECT_NEAR(lm.standard_error(0), std::sqrt((K + 1) / 12.0), 1e-12);
  // Replica 0 holds 0 and 2 (mean 1), every other replica one estimate of 1: every replica mean is 1, error 0.
  ASSERT_TRUE(lm.add(1, Rgb(0), 0));
  ASSERT_TRUE(lm.add(1, Rgb(2), 0));
  for (int r = 1; r < K; ++r) ASSERT_TRUE(lm.add(1, Rgb(1), r));
  EXPECT_NEAR(lm.mean(1).r, 1.0, 1e-15);
  EXPECT_NEAR(lm.standard_error(1), 0.0, 1e-15);
  // Unequal counts, by hand for K replicas: replica 0 holds {4, 4} (n = 2, mean 4), the others one estimate of 1.
  // N = K + 1, μ = (8 + K − 1)/(K + 1); s² = K/(K − 1) · Σ (n_r/N)² (m_r − μ)².
  ASSERT_TRUE(lm.add(3, Rgb(4), 0));
  ASSERT_TRUE(lm.add(3, Rgb(4), 0));
  for (int r = 1; r < K; ++r) ASSERT_TRUE(lm.add(3, Rgb(1), r));
  const double N = K + 1, mu = (8.0 + K - 1) / N;
  const double ss = (2 / N) * (2 / N) * (4 - mu) * (4 - mu) + (K - 1) * (1 / N) * (1 / N) * (1 - mu) * (1 - mu);
  EXPECT_NEAR(lm.standard_error(3), std::sqrt(ss * K / (K - 1)), 1e-12);
}

TEST(LightmapImage, NonFiniteNegativeAndInvalidEstimatesNeverReachATexel) {
  LightmapImage lm = small();
  EXPECT_FALSE(lm.add(0, Rgb(std::nan(""), 1, 1)));
  EXPECT_FALSE(lm.add(0, Rgb(1, std::numeric_limits<double>::infinity(), 1)));
  EXPECT_FALSE(lm.add(0, Rgb(1, 1, -1e-3)));
  EXPECT_FALSE(lm.add(2, Rgb(1)));  // texel 2 is invalid
  EXPECT_EQ(lm.count(0), 0u);
  EXPECT_EQ(lm.count(2), 0u);
  // A replica without an estimate: no error estimate.
  EXPECT_TRUE(std::isinf(lm.relative_error(0)));
  for (int r = 0; r + 1 < K; ++r) ASSERT_TRUE(lm.add(0, Rgb(1 + r)));
  EXPECT_TRUE(std::isinf(lm.relative_error(0)));
  ASSERT_TRUE(lm.add(0, Rgb(1)));
  EXPECT_TRUE(std::isfinite(lm.relative_error(0)));
  // Zero light, exactly: error 0 under either metric (a black texel, a black lightmap).
  for (int r = 0; r < K; ++r) ASSERT_TRUE(lm.add(1, Rgb(0)));
  EXPECT_EQ(lm.relative_error(1), 0.0);
  EXPECT_EQ(lm.error(1, ErrorMetric::lightmap, 0.0), 0.0);
}

TEST(LightmapImage, ErrorSummaryCountsWhatIsAboveTheTarget) {
  LightmapImage lm = small();
  for (int v = 1; v <= K; ++v) lm.add(0, Rgb(v));  // mean (K + 1)/2, standard error √((K + 1)/12)
  for (int r = 0; r < K; ++r) lm.add(1, Rgb(1));   // error 0
  lm.add(3, Rgb(1));                               // unestimated
  const double se0 = std::sqrt((K + 1) / 12.0), mean0 = (K + 1) / 2.0;
  const auto s = lm.error_summary(0.1);
  EXPECT_EQ(s.valid, 3u);
  EXPECT_EQ(s.estimated, 2u);
  EXPECT_EQ(s.above_target, 2u);  // texel 0 (0.18 for K = 8) and the unestimated texel 3
  EXPECT_EQ(s.estimates, static_cast<uint64_t>(2 * K + 1));
  EXPECT_NEAR(s.max, se0 / mean0, 1e-12);
  EXPECT_NEAR(s.rms, std::sqrt((se0 / mean0) * (se0 / mean0) / 2), 1e-12);
  // The lightmap metric: over the brightness, the mean of the three texel means (texel 3's one estimate counts).
  const double brightness = (mean0 + 1 + 1) / 3;
  const auto l = lm.error_summary(0.1, 0, ErrorMetric::lightmap);
  EXPECT_NEAR(l.brightness, brightness, 1e-12);
  EXPECT_NEAR(l.max, se0 / brightness, 1e-12);
  EXPECT_EQ(l.estimated, 2u);
}

TEST(LightmapImage, TheThreeFilesDecodeToWhatWasAccumulated) {
  // 3×1: texel 0 valid (estimates (1,2,3) and (3,4,5) replica by replica), texel 1 invalid, texel 2 valid (one
  // estimate (8,8,8)).
  LightmapImage lm("floor", 3, 1, {1, 0, 1});
  for (int r = 0; r < K; ++r) lm.add(0, r % 2 ? Rgb(3, 4, 5) : Rgb(1, 2, 3));
  lm.add(2, Rgb(8, 8, 8));
  LightmapOutputOptions options;
  options.padding = 1;
  const auto outputs = encode_lightmap(lm, options);
  ASSERT_EQ(outputs.size(), 3u);
  EXPECT_EQ(outputs[0].name, "floor_irradiance.exr");
  EXPECT_EQ(outputs[1].name, "floor_validity.exr");
  EXPECT_EQ(outputs[2].name, "floor_error.exr");

  const image::FloatImage irr = image::decode_exr(outputs[0].bytes);
  ASSERT_EQ(irr.width, 3);
  ASSERT_EQ(irr.height, 1);
  ASSERT_EQ(irr.channels, 3);
  // Means (2, 3, 4) and (8, 8, 8); the invalid texel between them is padded with their average (5, 5.5, 6). All
  // exact in float: the file stores float32 bit for bit.
  const float expected[9] = {2, 3, 4, 5, 5.5f, 6, 8, 8, 8};
  for (int i = 0; i < 9; ++i) EXPECT_EQ(irr.pixels[i], expected[i]) << i;
  EXPECT_EQ(irr.metadata.at("kiln:content"), "irradiance");
  EXPECT_EQ(irr.metadata.at("kiln:units"), "W/m^2");
  EXPECT_EQ(irr.metadata.at("kiln:colorspace"), "lin_rec709");
  EXPECT_EQ(irr.metadata.at("kiln:lightmap"), "floor");
  EXPECT_EQ(irr.metadata.at("kiln:resolution"), "3x1");
  EXPECT_EQ(irr.metadata.at("kiln:padding"), "1");
  EXPECT_NE(irr.metadata.at("kiln:uv_convention").find("v = 0"), std::string::npos);

  // Validity is the map before dilation.
  const image::FloatImage val = image::decode_exr(outputs[1].bytes);
  ASSERT_EQ(val.channels, 1);
  EXPECT_EQ(val.pixels, (std::vector<float>{1, 0, 1}));
  EXPECT_EQ(val.metadata.at("kiln:content"), "validity");

  // Error: texel 0's replica means alternate between Y(1,2,3) and Y(3,4,5); texel 2 has one estimate (reported as 1).
  const image::FloatImage err = image::decode_exr(outputs[2].bytes);
  ASSERT_EQ(err.channels, 1);
  EXPECT_EQ(err.pixels[0], static_cast<float>(lm.relative_error(0)));
  EXPECT_EQ(err.pixels[1], 0.0f);
  EXPECT_EQ(err.pixels[2], 1.0f);
  // Independently: K replica means alternating a, b have Σ (m_r − μ)² = K ((a − b)/2)², standard error
  // |a − b|/(2 √(K − 1)), mean (a + b)/2.
  const double ya = 0.2126 * 1 + 0.7152 * 2 + 0.0722 * 3, yb = 0.2126 * 3 + 0.7152 * 4 + 0.0722 * 5;
  EXPECT_NEAR(err.pixels[0], (std::fabs(ya - yb) / 2 / std::sqrt(K - 1.0)) / ((ya + yb) / 2),
              1e-7);  // float32 storage: 2⁻²⁴ relative
  EXPECT_EQ(err.metadata.at("kiln:content"), "relative error");
  EXPECT_EQ(err.metadata.at("kiln:error_metric"), "texel");

  // Under the lightmap metric the file says so and records the brightness it divided by.
  options.metric = ErrorMetric::lightmap;
  const image::FloatImage err_l = image::decode_exr(encode_lightmap(lm, options)[2].bytes);
  EXPECT_EQ(err_l.metadata.at("kiln:error_metric"), "lightmap");
  EXPECT_EQ(err_l.pixels[0], static_cast<float>(lm.error(0, ErrorMetric::lightmap, lm.brightness())));
  EXPECT_NE(err_l.metadata.count("kiln:brightness"), 0u);
}

TEST(LightmapImage, BadSizesAndOptionsAreRefused) {
  EXPECT_THROW(LightmapImage("x", 2, 2, {1, 1, 1}), std::invalid_argument);
  EXPECT_THROW(LightmapImage("x", 0, 2, {}), std::invalid_argument);
  LightmapImage lm = small();
  LightmapOutputOptions o;
  o.padding = -1;
  EXPECT_THROW(encode_lightmap(lm, o), std::invalid_argument);
  o.padding = 2;
  o.error_floor = std::nan("");
  EXPECT_THROW(encode_lightmap(lm, o), std::invalid_argument);
}

}  // namespace
}  // namespace kiln::lightmap
