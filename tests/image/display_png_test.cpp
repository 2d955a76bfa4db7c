// The previews' shared exposure rule and display encoding (bakers/image/display_png.h): the exposure against the
// median/mean rule worked by hand, the pixels against the sRGB curve written from IEC 61966-2-1, and the guards.
#include "bakers/image/display_png.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace kiln::image {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The sRGB encoding (inverse EOTF) of IEC 61966-2-1, independent of OpenColorIO.
double linear_to_srgb(double v) { return v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055; }

TEST(AutoExposure, MapsTheMedianToMidGrey) {
  // Sorted 1, 2, 3, 4, 100: the median is 3 whatever the outlier.
  const AutoExposure odd = auto_exposure({100, 2, 4, 1, 3});
  EXPECT_EQ(odd.from, AutoExposure::Key::median);
  EXPECT_EQ(odd.key, 3.0);
  EXPECT_EQ(odd.multiplier, kMidGrey / 3.0);  // one division: exact to the last bit
  // An even count takes the upper middle value (documented): 1, 2, 3, 4 → 3.
  EXPECT_EQ(auto_exposure({4, 1, 3, 2}).key, 3.0);
  // NaN is left out: the median of 1, 2, 3.
  EXPECT_EQ(auto_exposure({kNaN, 3, kNaN, 1, 2}).key, 2.0);
}

TEST(AutoExposure, ABlackMedianFallsBackToTheMeanAndABlackPictureToOne) {
  // Three of four black: the median is 0, the mean 1.
  const AutoExposure mostly_black = auto_exposure({0, 4, 0, 0});
  EXPECT_EQ(mostly_black.from, AutoExposure::Key::mean);
  EXPECT_EQ(mostly_black.key, 1.0);
  EXPECT_EQ(mostly_black.multiplier, kMidGrey);
  for (const std::vector<double>& black :
       {std::vector<double>{}, std::vector<double>{0, 0, 0}, std::vector<double>{kNaN}, std::vector<double>{1e-310}}) {
    // Empty, all black, all NaN, and a key whose 0.18 / key overflows: exposure 1.
    const AutoExposure e = auto_exposure(black);
    EXPECT_EQ(e.from, AutoExposure::Key::black);
    EXPECT_EQ(e.multiplier, 1.0);
  }
}

TEST(DisplayPng8, ExposesThenEncodesWithTheSrgbCurve) {
  // Linear values × exposure 0.5 across [0, 1], through the default view (kiln's "sRGB"/"Standard": clamp, sRGB curve).
  const std::vector<double> linear = {0.0, 0.002, 0.02, 0.18, 0.36, 0.5, 1.0, 1.6, 3.0};
  std::vector<float> rgb;
  for (double v : linear) rgb.insert(rgb.end(), 3, static_cast<float>(v));
  const Png8Image png = display_png8(rgb, 3, 3, 0.5, "lin_rec709");
  ASSERT_EQ(png.width, 3);
  ASSERT_EQ(png.height, 3);
  ASSERT_EQ(png.channels, 3);
  EXPECT_EQ(png.metadata.at("kiln:display_view"), "sRGB/Standard");
  for (size_t i = 0; i < linear.size(); ++i) {
    const double expected = 255.0 * linear_to_srgb(std::min(1.0, 0.5 * linear[i]));
    for (int c = 0; c < 3; ++c) {
      // Rounding to the nearest code (0.5) plus OpenColorIO's float evaluation of the curve (1e-6 of full scale,
      // 2.6e-4 codes; 0.01 leaves room).
      EXPECT_NEAR(png.pixels[3 * i + c], expected, 0.51) << "linear " << linear[i];
    }
  }
}

TEST(DisplayPng8, NotANumberAndNegativeValuesBecomeBlack) {
  // Raw view: the display transform passes values through, so the guard before it is what is seen.
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  const std::vector<float> rgb = {nan, -1.0f, -inf, inf, 0.25f, 2.0f};
  const Png8Image png = display_png8(rgb, 2, 1, 2.0, "lin_rec709", "sRGB", "Raw");
  EXPECT_EQ(png.metadata.at("kiln:display_view"), "sRGB/Raw");
  EXPECT_EQ(png.pixels[0], 0);    // NaN
  EXPECT_EQ(png.pixels[1], 0);    // negative
  EXPECT_EQ(png.pixels[2], 0);    // −Inf
  EXPECT_EQ(png.pixels[3], 255);  // +Inf is light beyond white: clamped
  EXPECT_EQ(png.pixels[4], 128);  // 0.25 × 2 = 0.5 → round(127.5) = 128
  EXPECT_EQ(png.pixels[5], 255);  // 4: clamped
}

TEST(DisplayPng8, BadArgumentsAreRefused) {
  const std::vector<float> one_pixel = {0.1f, 0.2f, 0.3f};
  EXPECT_THROW(display_png8(one_pixel, 2, 1, 1.0, "lin_rec709"), std::invalid_argument);  // 3 values for 2 pixels
  EXPECT_THROW(display_png8(one_pixel, 0, 0, 1.0, "lin_rec709"), std::invalid_argument);
  EXPECT_THROW(display_png8(one_pixel, 1, 1, 0.0, "lin_rec709"), std::invalid_argument);
  EXPECT_THROW(display_png8(one_pixel, 1, 1, kNaN, "lin_rec709"), std::invalid_argument);
  EXPECT_THROW(display_png8(one_pixel, 1, 1, 1.0, "no_such_space"), std::invalid_argument);
  EXPECT_THROW(display_png8(one_pixel, 1, 1, 1.0, "lin_rec709", "no_such_display"), std::invalid_argument);
}

}  // namespace
}  // namespace kiln::image
