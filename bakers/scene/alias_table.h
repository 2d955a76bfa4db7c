// Choosing one of n items in proportion to its weight in O(1): Walker's alias method, built by Vose's algorithm
// (Vose 1991, "A linear algorithm for generating random numbers with a given distribution"). Next-event estimation
// chooses a light, and an emissive triangle on it, once per path vertex; a binary search over a CDF (Distribution1D)
// costs a call and unpredictable branches there, this costs one multiply and one compare.
//
// Contract (as Distribution1D's for functions): negative and non-finite weights are read as 0; all-zero weights (or
// none: one zero item) fall back to the uniform choice and total() reports 0 so callers can tell. A sample never
// returns an item of zero weight unless every weight is zero. The pmf of an item is weight / Σ weights.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "bakers/math/constants.h"

namespace kiln::scene {

class AliasTable {
 public:
  AliasTable() : AliasTable(std::vector<double>{}) {}
  explicit AliasTable(const std::vector<double>& weights);

  int size() const { return static_cast<int>(cells_.size()); }
  double total() const { return total_; }  // Σ of the sanitised weights (0 for the uniform fallback)

  struct Choice {
    int index = 0;
    double pmf = 0;         // probability of `index` (never 0)
    double u_remapped = 0;  // what u had left after the choice, uniform in [0, 1): reusable as a fresh number
  };
  // u ∈ [0, 1): cell ⌊u·n⌋, then that cell's own item or its alias by the fraction left.
  Choice sample(double u) const {
    // u outside [0, 1) is clamped into it, NaN read as 0 (the comparison fails).
    const double x = (u >= 0 ? std::min(u, kOneMinusEpsilon) : 0.0) * static_cast<double>(cells_.size());
    const int i = std::min(static_cast<int>(x), size() - 1);
    const Cell& c = cells_[i];
    const double f = x - i;  // in [0, 1)
    Choice out;
    if (f < c.q) {
      out.index = i;
      out.u_remapped = f * c.inv_q;
    } else {
      out.index = c.alias;
      out.u_remapped = (f - c.q) * c.inv_rest;
    }
    out.pmf = pmf_[out.index];
    out.u_remapped = std::min(out.u_remapped, kOneMinusEpsilon);
    return out;
  }
  double pmf(int index) const { return index >= 0 && index < size() ? pmf_[index] : 0.0; }

 private:
  struct Cell {
    double q = 1;         // probability of keeping the cell's own item
    double inv_q = 1;     // 1/q (0 when q = 0: that branch is never taken)
    double inv_rest = 0;  // 1/(1 − q) (0 when q = 1: that branch is never taken)
    int alias = 0;
  };
  std::vector<Cell> cells_;
  std::vector<double> pmf_;
  double total_ = 0;
};

}  // namespace kiln::scene
