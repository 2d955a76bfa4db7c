// Per-texel accumulation: means and standard errors against hand-computed statistics, refusal of values that must
// never reach a texel, and the three EXR files decoded back (pixels bit for bit, metadata present).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "bakers/image/exr.h"
#include "bakers/lightmap/lightmap_image.h"

namespace kiln::lightmap {
namespace {

// 2×2 lightmap: texels 0, 1, 3 valid, 2 invalid.
LightmapImage small() { return LightmapImage("wall", 2, 2, {1, 1, 0, 1}); }

TEST(LightmapImage, MeanAndRelativeErrorMatchTheTextbookFormulas) {
  LightmapImage lm = small();
  // Grey estimates 1, 2, 3, 4 (luminance = the grey value: the Rec. 709 weights sum to 1): mean 2.5, sample variance
  // 5/3, standard error √(5/12), relative error √(5/12)/2.5.
  for (double v : {1.0, 2.0, 3.0, 4.0}) ASSERT_TRUE(lm.add(0, Rgb(v)));
  EXPECT_EQ(lm.count(0), 4u);
  // A dozen double operations: 1e-12 relative is far above their rounding, far below any formula error.
  EXPECT_NEAR(lm.mean(0).r, 2.5, 1e-12);
  EXPECT_NEAR(lm.relative_error(0), std::sqrt(5.0 / 12.0) / 2.5, 1e-12);
  // The floor only matters above the mean.
  EXPECT_NEAR(lm.relative_error(0, 1.0), std::sqrt(5.0 / 12.0) / 2.5, 1e-12);
  EXPECT_NEAR(lm.relative_error(0, 10.0), std::sqrt(5.0 / 12.0) / 10.0, 1e-12);

  // Coloured estimates: the error is that of the luminance Y = 0.2126 R + 0.7152 G + 0.0722 B.
  ASSERT_TRUE(lm.add(1, Rgb(1, 0, 0)));
  ASSERT_TRUE(lm.add(1, Rgb(0, 1, 0)));
  const double y1 = 0.2126, y2 = 0.7152, mean_y = (y1 + y2) / 2;
  const double var = ((y1 - mean_y) * (y1 - mean_y) + (y2 - mean_y) * (y2 - mean_y)) / 1.0;
  EXPECT_NEAR(lm.relative_error(1), std::sqrt(var / 2) / mean_y, 1e-12);
  EXPECT_NEAR(lm.mean(1).g, 0.5, 1e-15);

  // Identical estimates: no spread, error 0 (not a negative variance's NaN).
  ASSERT_TRUE(lm.add(3, Rgb(0.1, 0.2, 0.3)));
  ASSERT_TRUE(lm.add(3, Rgb(0.1, 0.2, 0.3)));
  ASSERT_TRUE(lm.add(3, Rgb(0.1, 0.2, 0.3)));
  EXPECT_LT(lm.relative_error(3), 1e-7);  // √(rounding of Σ Y² − n Ȳ²) / Ȳ: ~10⁻⁸ at worst
  EXPECT_GE(lm.relative_error(3), 0.0);
}

TEST(LightmapImage, NonFiniteNegativeAndInvalidEstimatesNeverReachATexel) {
  LightmapImage lm = small();
  EXPECT_FALSE(lm.add(0, Rgb(std::nan(""), 1, 1)));
  EXPECT_FALSE(lm.add(0, Rgb(1, std::numeric_limits<double>::infinity(), 1)));
  EXPECT_FALSE(lm.add(0, Rgb(1, 1, -1e-3)));
  EXPECT_FALSE(lm.add(2, Rgb(1)));  // texel 2 is invalid
  EXPECT_EQ(lm.count(0), 0u);
  EXPECT_EQ(lm.count(2), 0u);
  // Fewer than two estimates: no error estimate.
  EXPECT_TRUE(std::isinf(lm.relative_error(0)));
  ASSERT_TRUE(lm.add(0, Rgb(1)));
  EXPECT_TRUE(std::isinf(lm.relative_error(0)));
  // Zero light, exactly: error 0.
  ASSERT_TRUE(lm.add(1, Rgb(0)));
  ASSERT_TRUE(lm.add(1, Rgb(0)));
  EXPECT_EQ(lm.relative_error(1), 0.0);
}

TEST(LightmapImage, ErrorSummaryCountsWhatIsAboveTheTarget) {
  LightmapImage lm = small();
  for (double v : {1.0, 2.0, 3.0, 4.0}) lm.add(0, Rgb(v));  // error 0.2582
  for (double v : {1.0, 1.0}) lm.add(1, Rgb(v));            // error 0
  lm.add(3, Rgb(1));                                        // unestimated
  const auto s = lm.error_summary(0.1);
  EXPECT_EQ(s.valid, 3u);
  EXPECT_EQ(s.estimated, 2u);
  EXPECT_EQ(s.above_target, 2u);  // texel 0 and the unestimated texel 3
  EXPECT_EQ(s.estimates, 7u);
  const double e0 = std::sqrt(5.0 / 12.0) / 2.5;
  EXPECT_NEAR(s.max, e0, 1e-12);
  EXPECT_NEAR(s.rms, std::sqrt(e0 * e0 / 2), 1e-12);
}

TEST(LightmapImage, TheThreeFilesDecodeToWhatWasAccumulated) {
  // 3×1: texel 0 valid (estimates (1,2,3) and (3,4,5)), texel 1 invalid, texel 2 valid (one estimate (8,8,8)).
  LightmapImage lm("floor", 3, 1, {1, 0, 1});
  lm.add(0, Rgb(1, 2, 3));
  lm.add(0, Rgb(3, 4, 5));
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

  // Error: texel 0 has Y = 2.2268 and 3.7714... (two estimates); texel 2 has one estimate (reported as 1).
  const image::FloatImage err = image::decode_exr(outputs[2].bytes);
  ASSERT_EQ(err.channels, 1);
  EXPECT_EQ(err.pixels[0], static_cast<float>(lm.relative_error(0)));
  EXPECT_EQ(err.pixels[1], 0.0f);
  EXPECT_EQ(err.pixels[2], 1.0f);
  // Independently: two estimates a, b have standard error |a − b|/2, mean (a + b)/2.
  const double ya = 0.2126 * 1 + 0.7152 * 2 + 0.0722 * 3, yb = 0.2126 * 3 + 0.7152 * 4 + 0.0722 * 5;
  EXPECT_NEAR(err.pixels[0], (std::fabs(ya - yb) / 2) / ((ya + yb) / 2), 1e-7);  // float32 storage: 2⁻²⁴ relative
  EXPECT_EQ(err.metadata.at("kiln:content"), "relative error");
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
