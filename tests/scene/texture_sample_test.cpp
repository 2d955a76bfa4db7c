// Texture reads: bilinear reconstruction through the texel centres, wrap-around at the edges, v = 0 the top row.
// Expected values are computed by hand from the texel values; 1e-12 tolerates only double rounding of the weights.
#include "bakers/scene/texture_sample.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "tests/support/tolerance.h"

namespace kiln::scene {
namespace {

// 4 × 2 texels, texel (i, j) = (i + 10 j, 1, 0): a ramp along x in the red channel, the row in the tens.
Texture ramp() {
  Texture t;
  t.width = 4;
  t.height = 2;
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 4; ++i) t.texels.push_back(Rgb(i + 10.0 * j, 1, 0));
  return t;
}

double red(const Texture& t, double u, double v) { return sample_bilinear(t, {u, v}).r; }

TEST(TextureSample, TexelCentresReadTheirTexel) {
  const Texture t = ramp();
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 4; ++i)
      EXPECT_TRUE(kiln::test::close(red(t, (i + 0.5) / 4, (j + 0.5) / 2), i + 10.0 * j, 0, 1e-12));
}

TEST(TextureSample, BilinearBetweenCentres) {
  const Texture t = ramp();
  // Between the centres of columns 1 and 2, row 0: the mean, 1.5; a quarter of the way from column 0: 0.25.
  EXPECT_TRUE(kiln::test::close(red(t, 2.0 / 4, 0.25), 1.5, 0, 1e-12));
  EXPECT_TRUE(kiln::test::close(red(t, (0.5 + 0.25) / 4, 0.25), 0.25, 0, 1e-12));
  // Half-way between the rows (v = 0.5): the mean of 1 and 11.
  EXPECT_TRUE(kiln::test::close(red(t, 1.5 / 4, 0.5), 6, 0, 1e-12));
  // Green is 1 everywhere: the weights sum to 1.
  EXPECT_TRUE(kiln::test::close(sample_bilinear(t, {0.123, 0.877}).g, 1, 0, 1e-12));
}

TEST(TextureSample, WrapsAroundAndVZeroIsTheTopRow) {
  const Texture t = ramp();
  // u = 0 lies half-way between the centres of column 3 and (wrapping) column 0: (3 + 0) / 2.
  EXPECT_TRUE(kiln::test::close(red(t, 0.0, 0.25), 1.5, 0, 1e-12));
  // v = 0 lies half-way between row 0 (top) and, wrapping, row 1: (1 + 11) / 2 at column 1.
  EXPECT_TRUE(kiln::test::close(red(t, 1.5 / 4, 0.0), 6, 0, 1e-12));
  EXPECT_TRUE(kiln::test::close(red(t, 1.5 / 4, 0.25), 1, 0, 1e-12));  // the top row is row 0
  // Periodic: whole-number shifts of the UV read the same (up to the rounding of u + 3, v − 5: 1e-12).
  for (double u : {0.05, 0.4, 0.93})
    for (double v : {0.1, 0.6}) EXPECT_TRUE(kiln::test::close(red(t, u + 3, v - 5), red(t, u, v), 0, 1e-12));
  EXPECT_TRUE(std::isfinite(red(t, 1e300, -1e300)));
}

TEST(TextureSample, BadInputsNeverNaN) {
  const Texture t = ramp();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(red(t, nan, 0.5), 0);  // texel (0, 0)
  EXPECT_EQ(red(t, 0.5, INFINITY), 0);
  EXPECT_EQ(sample_bilinear(Texture{}, {0.5, 0.5}).r, 1);  // empty: the neutral tint
}

}  // namespace
}  // namespace kiln::scene
