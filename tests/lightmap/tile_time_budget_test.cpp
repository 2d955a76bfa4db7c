// The time budget of a tiled bake (bakers/lightmap/tile_time_budget.h): its rates and decisions against figures
// worked by hand, and a simulated level whose stages cost what the budget measures: the bake it plans ends within its
// limit and spends it, samples every tile when the limit allows a pass over each, and when the limit is below what no
// limit can skip samples nothing and ends after that. The simulation has no clock, so the test does not depend on
// the machine's speed.
#include <algorithm>
#include <cstddef>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "bakers/lightmap/tile_time_budget.h"

namespace kiln::lightmap {
namespace {

// Rates, s per texel² covered: a sampled tile's rasterization 0.015, probes 0.01 and the rest 0.005 (r_s = 0.03), its
// first pass 0.01, an unsampled tile 0.005; outputs 1 µs per page texel.
TileTimeBudget measured_budget() {
  TileTimeBudget b(false);
  b.sampled_raster(1.5, 100);
  b.probes(1.0, 100);
  b.sampled_rest(0.5, 100);
  b.first_pass(1.0, 100);
  b.unsampled_tile(0.5, 100);
  b.page_written(4.0, 4e6);
  return b;
}

// Sums and ratios of doubles of a few terms: rounding well below 1e-12 s.
constexpr double kExact = 1e-12;

TEST(TileTimeBudget, RatesAreTotalSecondsOverTotalWork) {
  TileTimeBudget b = measured_budget();
  EXPECT_NEAR(b.sampled_rate(), 0.03, kExact);
  EXPECT_NEAR(b.first_pass_rate(), 0.01, kExact);
  EXPECT_NEAR(b.unsampled_rate(), 0.005, kExact);
  EXPECT_NEAR(b.output_rate(), 1e-6, kExact);
  b.sampled_raster(1.5, 300);  // rasterization 3 s / 400
  b.probes(2.0, 300);          // probes 3 s / 400
  EXPECT_NEAR(b.sampled_rate(), 3.0 / 400 + 3.0 / 400 + 0.005, kExact);
  b.page_written(-1.0, 1e6);  // a clock read backwards is not a measurement
  b.unsampled_tile(1.0, 0);   // nor is a tile with no coverage
  EXPECT_NEAR(b.output_rate(), 1e-6, kExact);
  EXPECT_NEAR(b.unsampled_rate(), 0.005, kExact);
}

TEST(TileTimeBudget, PriorsStandInUntilARateIsMeasured) {
  TileTimeBudget b(false);
  EXPECT_EQ(b.output_rate(), kOutputSecondsPerTexel);
  EXPECT_EQ(TileTimeBudget(true).output_rate(), kOutputSecondsPerTexel + kDenoiseSecondsPerTexel);
  EXPECT_EQ(b.first_pass_rate(), 0.0);
  EXPECT_EQ(b.probes_rate(), 0.0);
  b.sampled_raster(2.0, 100);
  EXPECT_NEAR(b.unsampled_rate(), kUnsampledRasterShare * 0.02, kExact);
  // A sampled tile's probes and first pass: multiples of its rasterization until measured.
  EXPECT_NEAR(b.probes_rate(), kProbesRasterShare * 0.02, kExact);
  EXPECT_NEAR(b.first_pass_rate(), kFirstPassRasterShare * 0.02, kExact);
  EXPECT_NEAR(b.sampled_rate(), (1 + kProbesRasterShare) * 0.02, kExact);
  b.probes(0.5, 100);
  b.first_pass(1.5, 100);
  EXPECT_NEAR(b.probes_rate(), 0.005, kExact);
  EXPECT_NEAR(b.first_pass_rate(), 0.015, kExact);
  b.unsampled_tile(0.3, 100);
  EXPECT_NEAR(b.unsampled_rate(), 0.003, kExact);
}

TEST(TileTimeBudget, TheFirstTileIsSampledWhenTheOutputsLeaveTime) {
  const TileTimeBudget b(false);
  // Nothing measured: what must follow is the outputs' prior, 1 µs × 4e6 = 4 s.
  EXPECT_TRUE(b.should_sample({4.0 + 1e-9, 100, 1e6, 4e6}));
  EXPECT_FALSE(b.should_sample({4.0, 100, 1e6, 4e6}));
}

// Rasterized, a tile is probed only if its probes and first pass, forecast from its rasterization until measured, fit
// beside what must follow: with rasterization at 0.01 s per texel², (3 + 7)·0.01·100 = 10 s, and the outputs' 4 s.
TEST(TileTimeBudget, ATileIsProbedOnlyWhenItsForecastProbesAndFirstPassFit) {
  TileTimeBudget b(false);
  b.sampled_raster(1.0, 100);
  const double needed = (kProbesRasterShare + kFirstPassRasterShare) * 0.01 * 100;
  EXPECT_NEAR(needed, 10.0, kExact);
  EXPECT_TRUE(b.should_probe({4.0 + needed + 1e-9, 100, 0, 4e6}));
  EXPECT_FALSE(b.should_probe({4.0 + needed - 1e-9, 100, 0, 4e6}));
}

TEST(TileTimeBudget, ATileIsSampledWhenItsSetUpAndFirstPassFitBesideWhatMustFollow) {
  const TileTimeBudget b = measured_budget();
  // after(1100, 4e6) = 0.005·1100 + 4 = 9.5 s must be done anyway; the tile's extra set-up and first pass,
  // (0.03 − 0.005 + 0.01)·100 = 3.5 s: 13 s in all.
  EXPECT_NEAR(b.after(1100, 4e6), 9.5, kExact);
  EXPECT_TRUE(b.should_sample({13.0 + 1e-9, 100, 1000, 4e6}));
  EXPECT_FALSE(b.should_sample({13.0 - 1e-9, 100, 1000, 4e6}));
}

TEST(TileTimeBudget, ATileSamplesForItsShareWhenEveryTileCanHaveAPass) {
  const TileTimeBudget b = measured_budget();
  // What follows: after(900, 4e6) = 4.5 + 4 = 8.5 s; the other tiles' extra set-up (0.03 − 0.005)·900 = 22.5 s. With
  // 51 s left, 20 s to share: every tile's first pass (0.01·1000 = 10 s) fits, and a tenth of the coverage is its.
  EXPECT_NEAR(b.sampling_seconds({51, 100, 900, 4e6}), 2.0, 1e-9);
  // The last tile: everything but the outputs.
  EXPECT_NEAR(b.sampling_seconds({10, 100, 0, 4e6}), 6.0, 1e-9);
}

TEST(TileTimeBudget, WhenNotEveryTileCanHaveAPassATileGetsItsFirstPass) {
  const TileTimeBudget b = measured_budget();
  // 36 s left: 36 − 8.5 − 22.5 = 5 s to share, less than the 10 s of every tile's first pass: this tile gets its
  // own, 0.01·100 = 1 s; with 9 s left, what the outputs and the others' rasterization leave, 0.5 s.
  EXPECT_NEAR(b.sampling_seconds({36, 100, 900, 4e6}), 1.0, 1e-9);
  EXPECT_NEAR(b.sampling_seconds({9, 100, 900, 4e6}), 0.5, 1e-9);
  EXPECT_EQ(b.sampling_seconds({8, 100, 900, 4e6}), 0.0) << "nothing spare";
  // No first pass measured yet, and the others' extra set-up, (0.03 − 0.005)·1000 = 25 s, more than the 11 s that
  // the outputs (4 s) and their rasterization (at the prior, a quarter of the sampled one's: 0.005·1000 = 5 s) leave
  // of 20 s: the tile gets all 11.
  TileTimeBudget first(false);
  first.sampled_raster(2.0, 100);
  first.probes(1.0, 100);
  EXPECT_NEAR(first.sampling_seconds({20, 100, 1000, 4e6}), 11.0, 1e-9);
}

// A level as the simulation sees it: tiles of random coverage in pages of 2048², and what each stage really costs,
// seconds per texel² covered (per page texel for the outputs), about the generated level's (docs/PERFORMANCE.md).
struct Level {
  std::vector<std::vector<double>> pages;  // each page's tiles' coverage, texels²
  double page_texels = 2048.0 * 2048.0;
  double raster = 2.5e-6, probes = 7.5e-6, rest = 0.2e-6, pass = 20e-6, outputs = 0.65e-6;
  double unsampled = 0.5e-6, unsampled_raster = 0.3e-6;  // an unsampled tile, and of that its rasterization
};

Level generated_level(size_t page_count, size_t tiles_per_page) {
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> coverage(0.05e6, 0.9e6);  // a tile of 1024² a twentieth to nine tenths covered
  Level level;
  level.pages.resize(page_count);
  for (auto& p : level.pages) {
    for (size_t k = 0; k < tiles_per_page; ++k) p.push_back(coverage(rng));
  }
  return level;
}

struct Outcome {
  double seconds = 0;
  size_t sampled = 0, tiles = 0;
  double pass_coverage = 0;  // texels² that got a first pass's estimates
};

// Bakes `level` as lightmap_bake.cpp does, the clock advanced by each stage's true cost: a tile is sampled when the
// budget says so, before and after its rasterization, and samples until the time the budget gives it, its first pass
// cut short there (later passes, whose cost is the first's again, are cut as well); each page's outputs follow its
// tiles.
Outcome simulate(const Level& level, double limit) {
  TileTimeBudget budget(false);
  double coverage_left = 0;
  for (const auto& p : level.pages) {
    for (double c : p) coverage_left += c;
  }
  double page_texels_left = level.page_texels * static_cast<double>(level.pages.size());
  Outcome o;
  for (const auto& page : level.pages) {
    for (double c : page) {
      ++o.tiles;
      const double after = coverage_left - c;
      bool sample = budget.should_sample({limit - o.seconds, c, after, page_texels_left});
      if (sample) {
        o.seconds += level.raster * c;
        budget.sampled_raster(level.raster * c, c);
        sample = budget.should_probe({limit - o.seconds, c, after, page_texels_left});
        if (!sample) o.seconds += (level.unsampled - level.unsampled_raster) * c;  // the unsampled tile's rest
      } else {
        o.seconds += level.unsampled * c;
        budget.unsampled_tile(level.unsampled * c, c);
      }
      if (sample) {
        ++o.sampled;
        o.seconds += (level.probes + level.rest) * c;
        budget.probes(level.probes * c, c);
        budget.sampled_rest(level.rest * c, c);
        const double s = budget.sampling_seconds({limit - o.seconds, c, after, page_texels_left});
        const double first = std::min(s, level.pass * c);
        budget.first_pass(first, first / level.pass);
        o.pass_coverage += first / level.pass;
        o.seconds += s;  // the passes after the first run until the tile's time is up, or the tile is done
      }
      coverage_left = after;
    }
    o.seconds += level.outputs * level.page_texels;
    budget.page_written(level.outputs * level.page_texels, level.page_texels);
    page_texels_left -= level.page_texels;
  }
  return o;
}

// What no limit can skip: every tile rasterized unsampled, every page written.
double least_seconds(const Level& level) {
  double s = level.outputs * level.page_texels * static_cast<double>(level.pages.size());
  for (const auto& p : level.pages) {
    for (double c : p) s += level.unsampled * c;
  }
  return s;
}

double total_coverage(const Level& level) {
  double c = 0;
  for (const auto& p : level.pages) {
    for (double x : p) c += x;
  }
  return c;
}

TEST(TileTimeBudget, ASimulatedLevelEndsWithinItsLimitAndSpendsIt) {
  const Level level = generated_level(9, 16);
  const double least = least_seconds(level);
  // One first pass over every tile: the sampled set-up and the pass beside the unsampled rasterization.
  const double one_pass =
      least + (level.raster + level.probes + level.rest + level.pass - level.unsampled) * total_coverage(level);
  for (double limit : {least * 1.2, least * 2, one_pass * 0.5, one_pass, one_pass * 2, one_pass * 5}) {
    const Outcome o = simulate(level, limit);
    EXPECT_LE(o.seconds, limit * (1 + 1e-12)) << "limit " << limit << " s";
    // The forecasts are the true rates once measured, and the outputs' prior is above them: the limit is spent, but
    // for what the prior held back on the first page and a first pass that did not fit.
    EXPECT_GT(o.seconds, 0.9 * limit) << "limit " << limit << " s";
    EXPECT_GE(o.sampled, 1u) << "limit " << limit << " s";
    std::printf(
        "limit %.0f s (%.2f× the least, %.2f× one pass over all): ended at %.0f s, %zu of %zu tiles sampled, "
        "%.0f %% of the coverage with a first pass\n",
        limit, limit / least, limit / one_pass, o.seconds, o.sampled, o.tiles,
        100 * o.pass_coverage / total_coverage(level));
  }
  const Outcome ample = simulate(level, one_pass * 2);
  EXPECT_EQ(ample.sampled, ample.tiles) << "twice a first pass over all leaves no tile unsampled";
  EXPECT_NEAR(ample.pass_coverage, total_coverage(level), 1e-6 * total_coverage(level));
}

TEST(TileTimeBudget, ALimitBelowWhatCannotBeSkippedSamplesNothingAndEndsAfterIt) {
  const Level level = generated_level(9, 16);
  const double least = least_seconds(level);
  const Outcome o = simulate(level, least * 0.5);
  EXPECT_EQ(o.sampled, 0u);
  EXPECT_NEAR(o.seconds, least, 1e-9 * least);
}

}  // namespace
}  // namespace kiln::lightmap
