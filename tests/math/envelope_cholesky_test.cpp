// The envelope Cholesky solver (bakers/math/envelope_cholesky.h): the reverse Cuthill–McKee order against graphs whose
// best order is known, solutions against dense Gaussian elimination, and the refusals (budget, not positive definite).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <numeric>
#include <vector>

#include "bakers/math/envelope_cholesky.h"
#include "bakers/math/rng.h"

namespace kiln {
namespace {

// A symmetric matrix built entry by entry, then laid out in compressed rows (both triangles, by column).
struct Matrix {
  uint32_t n = 0;
  std::map<std::pair<uint32_t, uint32_t>, double> entries;
  std::vector<uint32_t> row_start, col;
  std::vector<double> value;

  explicit Matrix(uint32_t size) : n(size) {}
  void add(uint32_t i, uint32_t j, double v) {
    entries[{i, j}] += v;
    if (i != j) entries[{j, i}] += v;
  }
  // A coupling w (x_i − x_j)², as a seam's lookups add.
  void couple(uint32_t i, uint32_t j, double w) {
    add(i, i, w);
    add(j, j, w);
    add(i, j, -w);
  }
  void compress() {
    row_start.assign(n + 1, 0);
    col.clear();
    value.clear();
    for (const auto& [ij, v] : entries) {
      ++row_start[ij.first + 1];
      col.push_back(ij.second);
      value.push_back(v);
    }
    for (uint32_t i = 0; i < n; ++i) row_start[i + 1] += row_start[i];
  }
  SymmetricBlock block() const { return {row_start, col, value, 0, n}; }
  std::vector<double> times(const std::vector<double>& x) const {
    std::vector<double> y(n, 0.0);
    for (const auto& [ij, v] : entries) y[ij.first] += v * x[ij.second];
    return y;
  }
};

// Dense Gaussian elimination with partial pivoting, in long double: the reference solution.
std::vector<double> dense_solve(const Matrix& m, const std::vector<double>& b) {
  const uint32_t n = m.n;
  std::vector<std::vector<long double>> a(n, std::vector<long double>(n + 1, 0.0L));
  for (const auto& [ij, v] : m.entries) a[ij.first][ij.second] = v;
  for (uint32_t i = 0; i < n; ++i) a[i][n] = b[i];
  for (uint32_t c = 0; c < n; ++c) {
    uint32_t p = c;
    for (uint32_t r = c + 1; r < n; ++r) {
      if (std::abs(a[r][c]) > std::abs(a[p][c])) p = r;
    }
    std::swap(a[c], a[p]);
    for (uint32_t r = c + 1; r < n; ++r) {
      const long double f = a[r][c] / a[c][c];
      if (f == 0) continue;
      for (uint32_t k = c; k <= n; ++k) a[r][k] -= f * a[c][k];
    }
  }
  std::vector<double> x(n);
  for (uint32_t i = n; i-- > 0;) {
    long double s = a[i][n];
    for (uint32_t k = i + 1; k < n; ++k) s -= a[i][k] * x[k];
    x[i] = static_cast<double>(s / a[i][i]);
  }
  return x;
}

std::vector<uint32_t> shuffled(uint32_t n, uint64_t seed) {
  std::vector<uint32_t> p(n);
  std::iota(p.begin(), p.end(), 0u);
  Pcg32 rng(seed);
  for (uint32_t i = n; i > 1; --i) std::swap(p[i - 1], p[rng.next_u32() % i]);
  return p;
}

// A grid of w × h unknowns numbered in a scrambled order, neighbours coupled with weights spanning `spread` and every
// unknown held by a small weight of its own (as the seam system: seams weigh 1000, dilated texels 0.01).
Matrix scrambled_grid(uint32_t w, uint32_t h, double spread, uint64_t seed) {
  Matrix m(w * h);
  const std::vector<uint32_t> id = shuffled(w * h, seed);
  Pcg32 rng(seed + 1);
  const auto weight = [&] { return std::pow(spread, rng.uniform32()); };
  for (uint32_t y = 0; y < h; ++y) {
    for (uint32_t x = 0; x < w; ++x) {
      const uint32_t i = id[y * w + x];
      m.add(i, i, weight() / spread);
      if (x + 1 < w) m.couple(i, id[y * w + x + 1], weight());
      if (y + 1 < h) m.couple(i, id[(y + 1) * w + x], weight());
    }
  }
  m.compress();
  return m;
}

std::vector<double> random_vector(uint32_t n, uint64_t seed) {
  Pcg32 rng(seed);
  std::vector<double> b(n);
  for (double& v : b) v = 2.0 * rng.uniform32() - 1.0;
  return b;
}

// A path numbered at random: reverse Cuthill–McKee finds an end (the pseudo-peripheral row) and walks it, so every
// row's envelope is its diagonal and one neighbour, 2n − 1 values, exactly.
TEST(EnvelopeCholesky, FindsThePathInAScrambledPath) {
  const uint32_t n = 200;
  const std::vector<uint32_t> id = shuffled(n, 7);
  Matrix m(n);
  for (uint32_t k = 0; k < n; ++k) m.add(id[k], id[k], 1.0);
  for (uint32_t k = 0; k + 1 < n; ++k) m.couple(id[k], id[k + 1], 1000.0);
  m.compress();
  const std::vector<uint32_t> order = reverse_cuthill_mckee(m.block());
  ASSERT_EQ(order.size(), n);
  EXPECT_TRUE(order.front() == id.front() || order.front() == id.back());
  for (uint32_t k = 0; k + 1 < n; ++k) {
    const auto a = std::find(id.begin(), id.end(), order[k]) - id.begin();
    const auto b = std::find(id.begin(), id.end(), order[k + 1]) - id.begin();
    EXPECT_EQ(std::abs(a - b), 1) << "positions " << k << " and " << k + 1 << " are not neighbours on the path";
  }
  EnvelopeCholesky f;
  ASSERT_TRUE(f.factor(m.block(), std::numeric_limits<size_t>::max()));
  EXPECT_EQ(f.entries(), 2 * n - 1);
}

// On a scrambled grid the order's envelope is that of a banded matrix of about the grid's short side, not the
// scrambled numbering's: ≤ 2 · short side per row (Cuthill–McKee's levels are the grid's anti-diagonals).
TEST(EnvelopeCholesky, OrderKeepsAGridBanded) {
  const uint32_t w = 40, h = 12;
  const Matrix m = scrambled_grid(w, h, 1.0, 11);
  EnvelopeCholesky f;
  ASSERT_TRUE(f.factor(m.block(), std::numeric_limits<size_t>::max()));
  EXPECT_LE(f.entries(), size_t{2} * h * w * h) << "an envelope of " << f.entries() << " values";
  std::printf("scrambled %ux%u grid: envelope %zu values, %.1f per row\n", w, h, f.entries(),
              static_cast<double>(f.entries()) / (w * h));
}

// Solutions against dense elimination in long double, for weights spanning 1 (well conditioned) to 10⁵ (the seam
// system's spread, condition numbers to ~10⁷). Tolerance: the relative error of a backward-stable solve is about
// κ · 2⁻⁵³ ≈ 10⁻⁹ at κ = 10⁷; 10⁻⁸ leaves a factor of ten. The residual ‖Ax − b‖ / (‖A‖ ‖x‖) of Cholesky is a few
// units of 2⁻⁵³ times the envelope's width whatever κ: 10⁻¹³.
TEST(EnvelopeCholesky, MatchesDenseEliminationAcrossConditioning) {
  for (const double spread : {1.0, 1e3, 1e5}) {
    for (const uint64_t seed : {1u, 2u, 3u}) {
      const Matrix m = scrambled_grid(23, 9, spread, seed);
      const std::vector<double> b = random_vector(m.n, seed + 100);
      EnvelopeCholesky f;
      ASSERT_TRUE(f.factor(m.block(), std::numeric_limits<size_t>::max()));
      std::vector<double> x = b;
      f.solve(x.data());
      const std::vector<double> reference = dense_solve(m, b);
      double error = 0, size = 0, residual = 0, norm_a = 0, norm_x = 0;
      const std::vector<double> ax = m.times(x);
      for (uint32_t i = 0; i < m.n; ++i) {
        error = std::max(error, std::abs(x[i] - reference[i]));
        size = std::max(size, std::abs(reference[i]));
        residual = std::max(residual, std::abs(ax[i] - b[i]));
        norm_x = std::max(norm_x, std::abs(x[i]));
      }
      for (const auto& [ij, v] : m.entries) norm_a = std::max(norm_a, std::abs(v));
      EXPECT_LE(error, 1e-8 * size) << "spread " << spread << ", seed " << seed;
      EXPECT_LE(residual, 1e-13 * norm_a * norm_x * m.n) << "spread " << spread << ", seed " << seed;
    }
  }
}

// A block in the middle of a larger matrix (rows [lo, hi), as a seam component is), made of two parts that share no
// entry: each part is solved on its own terms, and rows outside the block are never read.
TEST(EnvelopeCholesky, SolvesABlockOfTwoPartsInsideALargerMatrix) {
  const Matrix part = scrambled_grid(6, 5, 100.0, 5);
  const uint32_t lo = 4, n = 2 * part.n, total = lo + n + 3;
  Matrix whole(total);
  for (uint32_t i = 0; i < lo; ++i) whole.add(i, i, std::numeric_limits<double>::quiet_NaN());
  for (uint32_t i = lo + n; i < total; ++i) whole.add(i, i, std::numeric_limits<double>::quiet_NaN());
  for (const auto& [ij, v] : part.entries) {
    whole.entries[{lo + ij.first, lo + ij.second}] = v;
    whole.entries[{lo + part.n + ij.first, lo + part.n + ij.second}] = 2 * v;
  }
  whole.compress();
  EnvelopeCholesky f;
  ASSERT_TRUE(f.factor({whole.row_start, whole.col, whole.value, lo, lo + n}, std::numeric_limits<size_t>::max()));
  ASSERT_EQ(f.size(), n);
  const std::vector<double> b = random_vector(part.n, 9);
  std::vector<double> x(b);
  x.insert(x.end(), b.begin(), b.end());
  f.solve(x.data());
  const std::vector<double> reference = dense_solve(part, b);
  for (uint32_t i = 0; i < part.n; ++i) {
    // Tolerance as above, for weights spanning 100.
    EXPECT_NEAR(x[i], reference[i], 1e-10 * std::abs(reference[i]) + 1e-14) << i;
    EXPECT_NEAR(x[part.n + i], reference[i] / 2, 1e-10 * std::abs(reference[i]) + 1e-14) << i;
  }
}

// What the caller must solve otherwise: a budget below the envelope, a matrix that is not positive definite, a NaN.
// Each leaves the solver empty.
TEST(EnvelopeCholesky, RefusesWhatItCannotFactor) {
  Matrix grid = scrambled_grid(8, 8, 10.0, 3);
  EnvelopeCholesky f;
  ASSERT_TRUE(f.factor(grid.block(), std::numeric_limits<size_t>::max()));
  const size_t needed = f.entries();
  EXPECT_FALSE(f.factor(grid.block(), needed - 1));
  EXPECT_EQ(f.size(), 0u);
  EXPECT_EQ(f.entries(), 0u);
  EXPECT_TRUE(f.factor(grid.block(), needed));

  Matrix indefinite(3);  // eigenvalues 3 and −1 in the first two rows
  indefinite.add(0, 0, 1.0);
  indefinite.add(1, 1, 1.0);
  indefinite.add(0, 1, 2.0);
  indefinite.add(2, 2, 1.0);
  indefinite.compress();
  EXPECT_FALSE(f.factor(indefinite.block(), 100));
  EXPECT_EQ(f.size(), 0u);

  grid.entries[{5, 5}] = std::numeric_limits<double>::quiet_NaN();
  grid.compress();
  EXPECT_FALSE(f.factor(grid.block(), std::numeric_limits<size_t>::max()));
  EXPECT_EQ(f.size(), 0u);
}

}  // namespace
}  // namespace kiln
