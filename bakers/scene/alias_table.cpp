#include "bakers/scene/alias_table.h"

#include <cmath>

namespace kiln::scene {

AliasTable::AliasTable(const std::vector<double>& weights) {
  const size_t n = std::max<size_t>(1, weights.size());
  std::vector<double> w(n, 0.0);
  for (size_t i = 0; i < weights.size(); ++i) w[i] = weights[i] > 0 && std::isfinite(weights[i]) ? weights[i] : 0.0;
  for (double x : w) total_ += x;
  if (!(total_ > 0) || !std::isfinite(total_)) {
    // No usable weight: the uniform choice, and total() says so.
    total_ = 0;
    std::fill(w.begin(), w.end(), 1.0);
  }
  const double sum = total_ > 0 ? total_ : static_cast<double>(n);
  pmf_.resize(n);
  for (size_t i = 0; i < n; ++i) pmf_[i] = w[i] / sum;

  // Vose: scaled probabilities p_i = n·pmf_i; each cell below 1 is topped up from one above 1.
  cells_.assign(n, Cell{});
  std::vector<double> p(n);
  std::vector<int> small, large;
  int heaviest = 0;
  for (size_t i = 0; i < n; ++i) {
    p[i] = pmf_[i] * static_cast<double>(n);
    (p[i] < 1.0 ? small : large).push_back(static_cast<int>(i));
    if (w[i] > w[heaviest]) heaviest = static_cast<int>(i);
  }
  while (!small.empty() && !large.empty()) {
    const int s = small.back(), l = large.back();
    small.pop_back();
    large.pop_back();
    cells_[s].q = p[s];
    cells_[s].alias = l;
    p[l] -= 1.0 - p[s];
    (p[l] < 1.0 ? small : large).push_back(l);
  }
  // What is left is 1 up to rounding: keep the item itself, except an item of zero weight (left over only by that
  // rounding), which always yields to the heaviest so that it can never be chosen.
  for (int i : large) cells_[i].q = 1.0, cells_[i].alias = i;
  for (int i : small) {
    cells_[i].q = w[i] > 0 ? 1.0 : 0.0;
    cells_[i].alias = heaviest;
  }
  // Zero weights have q = 0 by now (p = 0 in the loop, or left over above): their cells always give the alias.
  for (Cell& c : cells_) {
    c.inv_q = c.q > 0 ? 1.0 / c.q : 0.0;
    c.inv_rest = c.q < 1 ? 1.0 / (1.0 - c.q) : 0.0;
  }
}

}  // namespace kiln::scene
