#include "bakers/scene/distribution.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "bakers/math/constants.h"

namespace kiln::scene {

Distribution1D::Distribution1D(std::vector<double> f) : func_(std::move(f)) {
  if (func_.empty()) func_.push_back(0.0);
  for (double& v : func_) {
    if (!(v > 0) || !std::isfinite(v)) v = 0.0;  // negative, NaN, ±Inf: not a probability
  }
  const size_t n = func_.size();
  cdf_.assign(n + 1, 0.0);
  for (size_t i = 0; i < n; ++i) cdf_[i + 1] = cdf_[i] + func_[i];
  func_sum_ = cdf_[n];
  integral_ = func_sum_ / static_cast<double>(n);
  // An all-zero function (or one whose sum overflowed, which sanitising excludes unless n·max > DBL_MAX) has no
  // distribution of its own: sample uniformly rather than divide by zero.
  if (!(func_sum_ > 0) || !std::isfinite(func_sum_)) {
    fallback_ = true;
    integral_ = std::isfinite(func_sum_) ? 0.0 : integral_;
    std::fill(func_.begin(), func_.end(), 1.0);
    for (size_t i = 0; i < n; ++i) cdf_[i + 1] = static_cast<double>(i + 1);
    func_sum_ = static_cast<double>(n);
  }
  for (size_t i = 1; i <= n; ++i) cdf_[i] /= func_sum_;
  cdf_[n] = 1.0;  // exactly, whatever the rounding of the running sum
}

int Distribution1D::find_cell(double u) const {
  // The last i with cdf_[i] ≤ u: then cdf_[i] ≤ u < cdf_[i + 1], so cell i has non-zero probability (cells of zero
  // width are skipped because upper_bound passes over equal entries).
  const auto it = std::upper_bound(cdf_.begin(), cdf_.end(), u);
  const int i = static_cast<int>(it - cdf_.begin()) - 1;
  return std::clamp(i, 0, size() - 1);
}

Distribution1D::Continuous Distribution1D::sample_continuous(double u) const {
  u = std::clamp(u, 0.0, kOneMinusEpsilon);
  const int i = find_cell(u);
  const double width = cdf_[i + 1] - cdf_[i];
  // width > 0 by find_cell; the guard only protects against a u clamped onto the last boundary.
  const double t = width > 0 ? (u - cdf_[i]) / width : 0.0;
  Continuous s;
  s.cell = i;
  s.x = std::min((i + std::clamp(t, 0.0, 1.0)) / size(), kOneMinusEpsilon);
  s.pdf = func_[i] * size() / func_sum_;
  return s;
}

double Distribution1D::pdf(double x) const {
  if (!(x >= 0.0 && x <= 1.0)) return 0.0;
  const int i = std::min(static_cast<int>(x * size()), size() - 1);
  return func_[i] * size() / func_sum_;
}

Distribution2D::Distribution2D(const std::vector<double>& f, int nu, int nv) : nu_(nu), nv_(nv) {
  if (nu < 1 || nv < 1 || f.size() != static_cast<size_t>(nu) * static_cast<size_t>(nv))
    throw std::invalid_argument("Distribution2D: the table must hold nu × nv ≥ 1 values");
  conditional_.reserve(nv);
  std::vector<double> marginal(nv);
  for (int v = 0; v < nv; ++v) {
    conditional_.emplace_back(std::vector<double>(f.begin() + static_cast<ptrdiff_t>(v) * nu,
                                                  f.begin() + static_cast<ptrdiff_t>(v + 1) * nu));
    marginal[v] = conditional_.back().integral();
  }
  marginal_ = Distribution1D(std::move(marginal));
}

Distribution2D::Sample Distribution2D::sample(Point2 u) const {
  const auto mv = marginal_.sample_continuous(u.y);
  const auto cu = conditional_[mv.cell].sample_continuous(u.x);
  return {Point2{cu.x, mv.x}, mv.pdf * cu.pdf, cu.cell, mv.cell};
}

double Distribution2D::pdf(Point2 uv) const {
  if (!(uv.x >= 0.0 && uv.x <= 1.0 && uv.y >= 0.0 && uv.y <= 1.0)) return 0.0;
  const int iv = std::min(static_cast<int>(uv.y * nv_), nv_ - 1);
  return marginal_.pdf(uv.y) * conditional_[iv].pdf(uv.x);
}

}  // namespace kiln::scene
