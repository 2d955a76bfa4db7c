// Colour management: kiln's shipped OpenColorIO config against the defining formulas of its spaces.
#include "bakers/image/color.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>

namespace kiln::image {
namespace {

// The sRGB electro-optical transfer function, written from IEC 61966-2-1 (independent of OpenColorIO).
double srgb_to_linear(double v) { return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4); }

TEST(Color, ShippedConfigIsActiveWithoutOcio) {
  ::unsetenv("OCIO");
  const ColorConfig& c = ColorConfig::active();
  EXPECT_EQ(c.source(), "kiln's shipped config");
  EXPECT_EQ(c.working_space(), "lin_rec709");
  for (const char* s : {"lin_rec709", "srgb_texture", "acescg", "aces2065_1", "cie_xyz_d65", "srgb_display", "raw"}) {
    EXPECT_TRUE(c.has_space(s)) << s;
  }
  EXPECT_TRUE(c.has_space("scene_linear"));  // roles resolve too
}

TEST(Color, SrgbTextureDecodesWithTheStandardCurve) {
  const ColorConfig& c = ColorConfig::active();
  for (double v : {0.0, 0.01, 0.04045, 0.1, 0.5, 0.9, 1.0}) {
    float px[3] = {float(v), float(v), float(v)};
    c.convert(px, 1, 3, "srgb_texture", "lin_rec709");
    // OpenColorIO evaluates in float: 1e-6 absolute covers float rounding of values in [0, 1].
    EXPECT_NEAR(px[0], srgb_to_linear(v), 1e-6) << v;
  }
}

TEST(Color, PrimariesMatrixKeepsWhiteAndLuminance) {
  const ColorConfig& c = ColorConfig::active();
  // D65 white (1, 1, 1) in Rec.709 is Y = 1 in XYZ, and its luminance row is the Rec.709 luma weights.
  float white[3] = {1, 1, 1};
  c.convert(white, 1, 3, "lin_rec709", "cie_xyz_d65");
  EXPECT_NEAR(white[1], 1.0, 1e-6);
  // Rec.709's D65 white point x = 0.3127, y = 0.3290: X = x/y, Z = (1 − x − y)/y. The matrix is given to 9 digits
  // and applied in float: 1e-5 covers both.
  EXPECT_NEAR(white[0], 0.3127 / 0.3290, 1e-5);
  EXPECT_NEAR(white[2], (1.0 - 0.3127 - 0.3290) / 0.3290, 1e-5);
  float red[3] = {1, 0, 0};
  c.convert(red, 1, 3, "lin_rec709", "cie_xyz_d65");
  EXPECT_NEAR(red[1], 0.2126, 1e-4);
  // ACEScg keeps achromatic values achromatic (the Bradford adaptation maps D65 white to D60 white = (1,1,1)).
  float grey[4] = {0.18f, 0.18f, 0.18f, 0.5f};
  c.convert(grey, 1, 4, "lin_rec709", "acescg");
  EXPECT_NEAR(grey[0], 0.18, 1e-5);
  EXPECT_NEAR(grey[2], 0.18, 1e-5);
  EXPECT_EQ(grey[3], 0.5f);  // alpha untouched
  // And back.
  c.convert(grey, 1, 4, "acescg", "lin_rec709");
  EXPECT_NEAR(grey[1], 0.18, 1e-5);
}

TEST(Color, DataIsNeverConverted) {
  const ColorConfig& c = ColorConfig::active();
  float px[3] = {0.25f, -3.0f, 1e6f};
  c.convert(px, 1, 3, "raw", "lin_rec709");
  EXPECT_EQ(px[0], 0.25f);
  EXPECT_EQ(px[1], -3.0f);
  EXPECT_EQ(px[2], 1e6f);
}

TEST(Color, DisplayClampsAndEncodes) {
  const ColorConfig& c = ColorConfig::active();
  float px[3] = {4.0f, -1.0f, 0.214041f};
  c.convert(px, 1, 3, "lin_rec709", "srgb_display");
  EXPECT_NEAR(px[0], 1.0, 1e-6);
  EXPECT_NEAR(px[1], 0.0, 1e-6);
  EXPECT_NEAR(px[2], 0.5, 1e-5);
}

TEST(Color, UnknownSpaceIsNamed) {
  const ColorConfig& c = ColorConfig::active();
  float px[3] = {0, 0, 0};
  try {
    c.convert(px, 1, 3, "rec2020_pq", "lin_rec709");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'rec2020_pq'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("lin_rec709"), std::string::npos) << e.what();
  }
  EXPECT_THROW(c.convert(px, 1, 2, "raw", "raw"), std::invalid_argument);
  EXPECT_THROW(ColorConfig::from_text("not: [a config"), std::runtime_error);
}

}  // namespace
}  // namespace kiln::image
