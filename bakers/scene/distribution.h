// Piecewise-constant 1-D and 2-D distributions (pbrt-v4 §A.4.2 and §A.5.3, PiecewiseConstant1D/2D): sampling a
// tabulated non-negative function in proportion to its value, with the density of what was sampled. The environment
// light uses them to importance-sample its image over [0,1)². (Choosing among lights and emissive triangles is the
// alias table's: alias_table.h, O(1) instead of a binary search.)
//
// Contract: f is tabulated on n equal cells of [0, 1). Negative and non-finite entries are read as 0 (they cannot be a
// probability). A function that is zero everywhere (or empty input: one zero cell) falls back to the uniform
// distribution, so every sample and every density stays finite; `integral()` still reports 0 so callers can tell.
// A sample never lands in a cell of zero probability.
#pragma once

#include <cstddef>
#include <vector>

#include "bakers/math/sampling.h"

namespace kiln::scene {

class Distribution1D {
 public:
  Distribution1D() : Distribution1D(std::vector<double>{}) {}
  explicit Distribution1D(std::vector<double> f);

  int size() const { return static_cast<int>(func_.size()); }
  // ∫₀¹ f(x) dx = mean of the cells (0 for an all-zero function, even though sampling is then uniform).
  double integral() const { return integral_; }
  bool uniform_fallback() const { return fallback_; }

  struct Continuous {
    double x = 0;    // in [0, 1)
    double pdf = 0;  // density at x with respect to x: f(x) / ∫f (never 0 for a returned x)
    int cell = 0;
  };
  // Inverts the CDF at u ∈ [0, 1): linear within the cell.
  Continuous sample_continuous(double u) const;
  // Density at x ∈ [0, 1] (x = 1 reads the last cell; outside [0, 1]: 0).
  double pdf(double x) const;

 private:
  int find_cell(double u) const;
  std::vector<double> func_;  // sanitised values (uniform 1s in the fallback)
  std::vector<double> cdf_;   // size + 1 entries, cdf_[0] = 0, cdf_[size] = 1
  double integral_ = 0;
  double func_sum_ = 0;  // Σ func_ (after the fallback)
  bool fallback_ = false;
};

// f(u, v) on nu × nv cells of [0, 1)², row-major: f[v * nu + u]. Samples v from the marginal (row sums) and then u
// from that row's conditional.
class Distribution2D {
 public:
  Distribution2D() = default;
  // Throws std::invalid_argument if nu or nv < 1 or f.size() != nu·nv.
  Distribution2D(const std::vector<double>& f, int nu, int nv);

  int nu() const { return nu_; }
  int nv() const { return nv_; }
  double integral() const { return marginal_.integral(); }  // ∫∫ f du dv
  bool uniform_fallback() const { return marginal_.uniform_fallback(); }

  struct Sample {
    Point2 uv;       // in [0, 1)²
    double pdf = 0;  // density with respect to du dv
    int iu = 0, iv = 0;
  };
  Sample sample(Point2 u) const;
  double pdf(Point2 uv) const;  // outside [0, 1]²: 0

 private:
  int nu_ = 0, nv_ = 0;
  std::vector<Distribution1D> conditional_;  // one per row v
  Distribution1D marginal_;
};

}  // namespace kiln::scene
