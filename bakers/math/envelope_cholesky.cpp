#include "bakers/math/envelope_cholesky.h"

#include <algorithm>
#include <cmath>
#include <tuple>

namespace kiln {

namespace {

uint32_t degree(const SymmetricBlock& a, uint32_t u) {
  const uint32_t row = a.lo + u;
  uint32_t d = 0;
  for (uint32_t e = a.row_start[row]; e < a.row_start[row + 1]; ++e) d += a.col[e] != row;
  return d;
}

// Breadth-first levels of the part holding `root`, in `queue`; returns the number of levels and where the last one
// begins in the queue. `seen` marks the rows reached with `stamp`, a number no earlier search used.
uint32_t levels_from(const SymmetricBlock& a, uint32_t root, std::vector<uint32_t>& seen, uint32_t stamp,
                     std::vector<uint32_t>& queue, size_t& last_level) {
  queue.assign(1, root);
  seen[root] = stamp;
  uint32_t levels = 0;
  for (size_t begin = 0; begin < queue.size();) {
    const size_t end = queue.size();
    last_level = begin;
    ++levels;
    for (size_t h = begin; h < end; ++h) {
      const uint32_t row = a.lo + queue[h];
      for (uint32_t e = a.row_start[row]; e < a.row_start[row + 1]; ++e) {
        const uint32_t v = a.col[e] - a.lo;
        if (seen[v] == stamp) continue;
        seen[v] = stamp;
        queue.push_back(v);
      }
    }
    begin = end;
  }
  return levels;
}

// George and Liu's pseudo-peripheral row of the part holding `root`: from the lowest-degree row of the last level,
// search again while that makes the level structure deeper.
uint32_t pseudo_peripheral(const SymmetricBlock& a, uint32_t root, const std::vector<uint32_t>& degrees,
                           std::vector<uint32_t>& seen, uint32_t& stamp, std::vector<uint32_t>& queue) {
  size_t last = 0;
  uint32_t depth = levels_from(a, root, seen, ++stamp, queue, last);
  for (;;) {
    uint32_t candidate = queue[last];
    for (size_t h = last; h < queue.size(); ++h) {
      const uint32_t v = queue[h];
      if (std::tie(degrees[v], v) < std::tie(degrees[candidate], candidate)) candidate = v;
    }
    const uint32_t candidate_depth = levels_from(a, candidate, seen, ++stamp, queue, last);
    if (candidate_depth <= depth) return root;
    root = candidate;
    depth = candidate_depth;
  }
}

}  // namespace

std::vector<uint32_t> reverse_cuthill_mckee(const SymmetricBlock& a) {
  const uint32_t n = a.hi - a.lo;
  std::vector<uint32_t> degrees(n);
  for (uint32_t u = 0; u < n; ++u) degrees[u] = degree(a, u);
  std::vector<uint32_t> order;
  order.reserve(n);
  std::vector<uint8_t> placed(n, 0);
  std::vector<uint32_t> seen(n, 0), queue, next;
  uint32_t stamp = 0;
  for (uint32_t lowest = 0; lowest < n; ++lowest) {
    if (placed[lowest]) continue;
    const size_t part_begin = order.size();
    const uint32_t start = pseudo_peripheral(a, lowest, degrees, seen, stamp, queue);
    order.push_back(start);
    placed[start] = 1;
    for (size_t h = part_begin; h < order.size(); ++h) {
      const uint32_t row = a.lo + order[h];
      next.clear();
      for (uint32_t e = a.row_start[row]; e < a.row_start[row + 1]; ++e) {
        const uint32_t v = a.col[e] - a.lo;
        if (placed[v]) continue;
        placed[v] = 1;
        next.push_back(v);
      }
      std::sort(next.begin(), next.end(),
                [&](uint32_t x, uint32_t y) { return std::tie(degrees[x], x) < std::tie(degrees[y], y); });
      order.insert(order.end(), next.begin(), next.end());
    }
    std::reverse(order.begin() + static_cast<std::ptrdiff_t>(part_begin), order.end());
  }
  return order;
}

void EnvelopeCholesky::clear() {
  order_ = {};
  first_ = {};
  start_ = {};
  values_ = {};
}

size_t EnvelopeCholesky::bytes() const {
  return order_.capacity() * sizeof(uint32_t) + first_.capacity() * sizeof(uint32_t) +
         start_.capacity() * sizeof(size_t) + values_.capacity() * sizeof(double);
}

size_t EnvelopeCholesky::bytes_for(size_t rows, size_t entries) {
  return 2 * rows * sizeof(uint32_t) + (rows + 1) * sizeof(size_t) + entries * sizeof(double);
}

bool EnvelopeCholesky::factor(const SymmetricBlock& a, size_t max_entries) {
  clear();
  const uint32_t n = a.hi - a.lo;
  std::vector<uint32_t> order = reverse_cuthill_mckee(a);
  std::vector<uint32_t> position(n);
  for (uint32_t i = 0; i < n; ++i) position[order[i]] = i;
  // The envelope: each row from its leftmost entry to its diagonal.
  std::vector<uint32_t> first(n);
  std::vector<size_t> start(n + 1);
  size_t total = 0;
  for (uint32_t i = 0; i < n; ++i) {
    const uint32_t row = a.lo + order[i];
    uint32_t f = i;
    for (uint32_t e = a.row_start[row]; e < a.row_start[row + 1]; ++e) f = std::min(f, position[a.col[e] - a.lo]);
    first[i] = f;
    start[i] = total;
    total += i - f + 1;
    if (total > max_entries) return false;
  }
  start[n] = total;
  values_.assign(total, 0.0);
  for (uint32_t i = 0; i < n; ++i) {
    const uint32_t row = a.lo + order[i];
    for (uint32_t e = a.row_start[row]; e < a.row_start[row + 1]; ++e) {
      const uint32_t j = position[a.col[e] - a.lo];
      if (j <= i) values_[start[i] + (j - first[i])] += a.value[e];
    }
  }
  order_ = std::move(order);
  first_ = std::move(first);
  start_ = std::move(start);
  // Row by row: L_ij = (A_ij − Σ_k L_ik L_jk) / L_jj over the columns both envelopes hold, then the diagonal.
  for (uint32_t i = 0; i < n; ++i) {
    double* li = &values_[start_[i]];
    const uint32_t fi = first_[i];
    for (uint32_t j = fi; j < i; ++j) {
      const double* lj = &values_[start_[j]];
      const uint32_t fj = first_[j];
      double sum = li[j - fi];
      for (uint32_t k = std::max(fi, fj); k < j; ++k) sum -= li[k - fi] * lj[k - fj];
      li[j - fi] = sum / lj[j - fj];
    }
    double pivot = li[i - fi];
    for (uint32_t k = fi; k < i; ++k) pivot -= li[k - fi] * li[k - fi];
    // A pivot at or below zero, or not finite: the matrix is not positive definite as rounded (or holds a NaN).
    if (!(pivot > 0) || !std::isfinite(pivot)) {
      clear();
      return false;
    }
    li[i - fi] = std::sqrt(pivot);
  }
  return true;
}

void EnvelopeCholesky::solve(double* x) const {
  const size_t n = order_.size();
  std::vector<double> y(n);
  for (size_t i = 0; i < n; ++i) y[i] = x[order_[i]];
  for (size_t i = 0; i < n; ++i) {  // L y' = y
    const double* li = &values_[start_[i]];
    const uint32_t fi = first_[i];
    double sum = y[i];
    for (uint32_t k = fi; k < i; ++k) sum -= li[k - fi] * y[k];
    y[i] = sum / li[i - fi];
  }
  for (size_t i = n; i-- > 0;) {  // Lᵀ z = y', by columns of Lᵀ (the rows of L)
    const double* li = &values_[start_[i]];
    const uint32_t fi = first_[i];
    y[i] /= li[i - fi];
    for (uint32_t k = fi; k < i; ++k) y[k] -= li[k - fi] * y[i];
  }
  for (size_t i = 0; i < n; ++i) x[order_[i]] = y[i];
}

}  // namespace kiln
