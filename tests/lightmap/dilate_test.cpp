// Padding of lightmaps: hand-computed averages ring by ring, the reach of the padding in Chebyshev distance, and a
// validity map that does not change.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>

#include "bakers/lightmap/dilate.h"

namespace kiln::lightmap {
namespace {

image::FloatImage grey(int w, int h) {
  image::FloatImage img;
  img.width = w;
  img.height = h;
  img.channels = 1;
  img.pixels.assign(static_cast<size_t>(w) * h, 0.0f);
  return img;
}

// Averages of at most three floats that are small integers or halves: exact in float, so the comparisons are exact.
TEST(Dilate, TwoValidTexelsFillTheRingsWithHandComputedAverages) {
  // Row 0: 1 _ 3; rows 1 and 2 invalid.
  image::FloatImage img = grey(3, 3);
  img.at(0, 0, 0) = 1;
  img.at(2, 0, 0) = 3;
  const std::vector<uint8_t> valid{1, 0, 1, 0, 0, 0, 0, 0, 0};

  // Ring 1: (1,0) and (1,1) see both valid texels, (1 + 3)/2; (0,1) sees 1 only; (2,1) sees 3 only. Row 2 is at
  // distance 2: beyond a padding of 1, left as it was.
  image::FloatImage one = img;
  EXPECT_EQ(dilate(one, valid, 1), 4u);
  EXPECT_EQ(one.pixels, (std::vector<float>{1, 2, 3,  //
                                            1, 2, 3,  //
                                            0, 0, 0}));
  // Ring 2 averages ring 1 (never itself): (0,2) sees (0,1) = 1 and (1,1) = 2; (1,2) sees 1, 2, 3; (2,2) sees 2, 3.
  // The valid texels are untouched.
  image::FloatImage two = img;
  EXPECT_EQ(dilate(two, valid, 2), 7u);
  EXPECT_EQ(two.pixels, (std::vector<float>{1, 2, 3,  //
                                            1, 2, 3,  //
                                            1.5f, 2, 2.5f}));
}

TEST(Dilate, PaddingReachesExactlyTheChebyshevDistanceAndKeepsTheValidityMap) {
  // One valid texel in the middle of 9×9 with every channel distinct: padding p fills the (2p+1)² square around it
  // with its value (every neighbour average is of copies of it) and nothing else.
  for (int p = 0; p <= 5; ++p) {
    image::FloatImage img;
    img.width = img.height = 9;
    img.channels = 3;
    img.pixels.assign(9 * 9 * 3, 0.0f);
    for (int c = 0; c < 3; ++c) img.at(4, 4, c) = 0.25f * (c + 1);
    std::vector<uint8_t> valid(81, 0);
    valid[4 * 9 + 4] = 1;
    const std::vector<uint8_t> before = valid;
    const int reach = std::min(p, 4);
    EXPECT_EQ(dilate(img, valid, p), static_cast<size_t>((2 * reach + 1) * (2 * reach + 1) - 1));
    EXPECT_EQ(valid, before);
    for (int y = 0; y < 9; ++y) {
      for (int x = 0; x < 9; ++x) {
        const bool inside = std::max(std::abs(x - 4), std::abs(y - 4)) <= p;
        for (int c = 0; c < 3; ++c) {
          EXPECT_EQ(img.at(x, y, c), inside ? 0.25f * (c + 1) : 0.0f) << "p " << p << " at " << x << "," << y;
        }
      }
    }
  }
}

TEST(Dilate, AChartEdgeAveragesAlongTheEdge) {
  // Valid column 0 holding 0, 4, 8, 12 (top to bottom); column 1 is ring 1. Each ring-1 texel averages the valid
  // texels among its neighbours: rows 0 and 3 see two, rows 1 and 2 see three.
  image::FloatImage img = grey(2, 4);
  std::vector<uint8_t> valid(8, 0);
  for (int y = 0; y < 4; ++y) {
    img.at(0, y, 0) = 4.0f * y;
    valid[y * 2] = 1;
  }
  dilate(img, valid, 3);
  EXPECT_EQ(img.at(1, 0, 0), 2.0f);   // (0 + 4)/2
  EXPECT_EQ(img.at(1, 1, 0), 4.0f);   // (0 + 4 + 8)/3
  EXPECT_EQ(img.at(1, 2, 0), 8.0f);   // (4 + 8 + 12)/3
  EXPECT_EQ(img.at(1, 3, 0), 10.0f);  // (8 + 12)/2
}

TEST(Dilate, NothingValidFillsNothingAndAWrongMapIsRefused) {
  image::FloatImage img = grey(4, 4);
  EXPECT_EQ(dilate(img, std::vector<uint8_t>(16, 0), 3), 0u);
  for (float v : img.pixels) EXPECT_EQ(v, 0.0f);
  EXPECT_THROW(dilate(img, std::vector<uint8_t>(15, 0), 1), std::invalid_argument);
}

}  // namespace
}  // namespace kiln::lightmap
