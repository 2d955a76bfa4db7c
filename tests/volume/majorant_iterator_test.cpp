// The majorant segments a DDA walk gives: contiguous, in order, covering the ray's stretch in the grid, each bounding
// the density everywhere on it; and empty leaves giving zero majorants.
#include "bakers/volume/majorant_iterator.h"

#include <gtest/gtest.h>

#include "bakers/math/rng.h"
#include "bakers/volume/grid_medium.h"
#include "tests/volume/media_test_util.h"

namespace kiln::volume {
namespace {

TEST(MajorantIterator, SingleSegmentAndEmpty) {
  MajorantIterator one = MajorantIterator::single(0.5, 2.0, {1, 2, 3});
  const auto s = one.next();
  ASSERT_TRUE(s);
  EXPECT_EQ(s->t_min, 0.5);
  EXPECT_EQ(s->t_max, 2.0);
  EXPECT_EQ(s->sigma_maj, Rgb(1, 2, 3));
  EXPECT_FALSE(one.next());
  EXPECT_FALSE(MajorantIterator::single(2.0, 1.0, Rgb(1)).next());
  EXPECT_FALSE(MajorantIterator().next());
}

// Segments tile [entry, exit) exactly (each starts where the previous ended) and bound sigma_t at 50 points along
// each: the bound must hold exactly (no tolerance: the majorant is a max over the voxels the interpolation reads).
TEST(MajorantIterator, GridSegmentsAreContiguousAndBoundTheDensity) {
  const GridMedium ball({test::lumpy_ball_grid(), {}, {}, {1, 0.5, 2}, {0.5, 0.5, 0.5}, {}, 0.0});
  Pcg32 rng(17);
  int zero_segments = 0;
  for (int r = 0; r < 200; ++r) {
    const scene::Ray ray{{rng.uniform() * 2 - 0.5, rng.uniform() * 2 - 0.5, -0.5},
                         {rng.uniform() - 0.5, rng.uniform() - 0.5, 1}};
    MajorantIterator it = ball.majorants(ray, 2.0);
    double last = -1;
    while (const auto s = it.next()) {
      if (last >= 0) {
        EXPECT_EQ(s->t_min, last);
      }
      EXPECT_LT(s->t_min, s->t_max);
      last = s->t_max;
      if (s->sigma_maj.max() == 0) ++zero_segments;
      for (int k = 0; k < 50; ++k) {
        const double t = s->t_min + (s->t_max - s->t_min) * (k + 0.5) / 50;
        const Rgb sigma_t = ball.at(ray.origin + ray.direction * t).sigma_t();
        for (int c = 0; c < 3; ++c) EXPECT_LE(sigma_t[c], s->sigma_maj[c]) << "ray " << r << " t " << t;
      }
    }
  }
  // The ball leaves the grid's corner leaves empty: rays through them get zero majorants (skipped space).
  EXPECT_GT(zero_segments, 0);
}

TEST(MajorantIterator, RayParallelToAnAxisAndMissingRay) {
  const GridMedium ball({test::lumpy_ball_grid(), {}, {}, {1, 1, 1}, {0, 0, 0}, {}, 0.0});
  MajorantIterator along = ball.majorants({{0.5, 0.5, -1}, {0, 0, 1}}, 10);
  double covered = 0;
  while (const auto s = along.next()) covered += s->t_max - s->t_min;
  EXPECT_GT(covered, 1.0);  // the majorant grid's box plus its one-voxel reach
  EXPECT_FALSE(ball.majorants({{5, 5, 5}, {1, 0, 0}}, 10).next());
}

}  // namespace
}  // namespace kiln::volume
