// The alias table: items chosen in proportion to their weights (χ² against the pmf), the remapped number uniform
// and independent of the choice, zero weights never chosen, and the guarded cases (all-zero, non-finite, empty).
#include "bakers/scene/alias_table.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "bakers/math/rng.h"
#include "tests/support/chi2.h"

namespace kiln::scene {
namespace {

using test::pearson_chi2;

// Three χ² tests run in this file: the family-wise false-rejection rate is held at 1 % by Šidák's correction.
const double kLevel = test::sidak_significance(0.01, 3);

TEST(AliasTable, ChoicesFollowTheWeights) {
  const std::vector<double> w = {0.5, 2.0, 0.0, 7.0, 1.0, 0.25, 3.0, 0.0, 1e-3};
  const AliasTable table(w);
  double sum = 0;
  for (double x : w) sum += x;
  EXPECT_DOUBLE_EQ(table.total(), sum);
  const int64_t n = 400000;
  std::vector<double> observed(w.size(), 0), expected(w.size(), 0);
  for (size_t i = 0; i < w.size(); ++i) {
    // The pmf is weight / total (to rounding).
    EXPECT_NEAR(table.pmf(static_cast<int>(i)), w[i] / sum, 1e-15);
    expected[i] = n * w[i] / sum;
  }
  Pcg32 rng(5);
  for (int64_t k = 0; k < n; ++k) {
    const AliasTable::Choice c = table.sample(rng.uniform());
    ASSERT_GE(c.index, 0);
    ASSERT_LT(c.index, table.size());
    ASSERT_GT(w[c.index], 0.0) << "an item of zero weight was chosen";
    ASSERT_EQ(c.pmf, table.pmf(c.index));
    ASSERT_GE(c.u_remapped, 0.0);
    ASSERT_LT(c.u_remapped, 1.0);
    observed[c.index] += 1;
  }
  const auto r = pearson_chi2(observed, expected);
  EXPECT_GT(r.p_value, kLevel) << "chi2 " << r.statistic << " dof " << r.dof << "\n" << r.worst;
}

TEST(AliasTable, RemappedNumberIsUniformWithinEveryChoice) {
  // Next-event estimation reuses u_remapped as a fresh number (the point on the chosen emissive triangle): it must
  // be uniform given the item, not only overall. 16 bins per item for the three items of unequal weight.
  const std::vector<double> w = {1.0, 5.0, 2.5};
  const AliasTable table(w);
  const int bins = 16;
  const int64_t n = 480000;
  std::vector<double> observed(w.size() * bins, 0), expected(w.size() * bins, 0);
  for (size_t i = 0; i < w.size(); ++i) {
    for (int b = 0; b < bins; ++b) expected[i * bins + b] = n * table.pmf(static_cast<int>(i)) / bins;
  }
  Pcg32 rng(11);
  for (int64_t k = 0; k < n; ++k) {
    const AliasTable::Choice c = table.sample(rng.uniform());
    observed[c.index * bins + std::min(static_cast<int>(c.u_remapped * bins), bins - 1)] += 1;
  }
  const auto r = pearson_chi2(observed, expected);
  EXPECT_GT(r.p_value, kLevel) << "chi2 " << r.statistic << " dof " << r.dof << "\n" << r.worst;
}

TEST(AliasTable, ManyItemsOfVeryDifferentWeights) {
  // 1000 items spanning twelve orders of magnitude, as emissive triangles of a scene can: every choice has weight,
  // and the frequencies follow the weights (the tiny ones pooled by the χ² test).
  std::vector<double> w(1000);
  for (size_t i = 0; i < w.size(); ++i) w[i] = std::pow(10.0, -12.0 * static_cast<double>(i % 37) / 36.0);
  const AliasTable table(w);
  const int64_t n = 500000;
  std::vector<double> observed(w.size(), 0), expected(w.size(), 0);
  for (size_t i = 0; i < w.size(); ++i) expected[i] = n * table.pmf(static_cast<int>(i));
  Pcg32 rng(17);
  for (int64_t k = 0; k < n; ++k) observed[table.sample(rng.uniform()).index] += 1;
  const auto r = pearson_chi2(observed, expected);
  EXPECT_GT(r.p_value, kLevel) << "chi2 " << r.statistic << " dof " << r.dof << "\n" << r.worst;
}

TEST(AliasTable, GuardedCases) {
  // All zero, negative or non-finite: the uniform choice, and total() = 0 says there was nothing to choose by.
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  for (const std::vector<double>& w :
       {std::vector<double>{0, 0, 0}, std::vector<double>{-1, nan, -inf}, std::vector<double>{0, inf, 0}}) {
    const AliasTable table(w);
    EXPECT_EQ(table.total(), 0.0);
    for (int i = 0; i < 3; ++i) EXPECT_DOUBLE_EQ(table.pmf(i), 1.0 / 3.0);
    for (double u : {0.0, 0.2, 0.5, 0.9, 1.0, -1.0, 2.0, nan}) {
      const AliasTable::Choice c = table.sample(u);
      EXPECT_GE(c.index, 0);
      EXPECT_LT(c.index, 3);
      EXPECT_GE(c.u_remapped, 0.0);
      EXPECT_LT(c.u_remapped, 1.0);
    }
  }
  // Empty: one item of zero weight, chosen always.
  const AliasTable empty{std::vector<double>{}};
  EXPECT_EQ(empty.size(), 1);
  EXPECT_EQ(empty.sample(0.7).index, 0);
  EXPECT_EQ(empty.pmf(1), 0.0);
  EXPECT_EQ(empty.pmf(-1), 0.0);
  // One item with weight: chosen always, u passes through whole.
  const AliasTable single{std::vector<double>{0, 3, 0}};
  for (double u : {0.0, 0.1, 0.5, 0.99}) {
    const AliasTable::Choice c = single.sample(u);
    EXPECT_EQ(c.index, 1);
    EXPECT_DOUBLE_EQ(c.pmf, 1.0);
  }
}

}  // namespace
}  // namespace kiln::scene
