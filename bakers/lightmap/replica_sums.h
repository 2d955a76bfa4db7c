// A texel's estimates grouped by replica (path_sampler.h): per replica the sum of the estimates' luminances and their
// count, from which the standard error of the texel's mean follows without assuming the estimates independent.
//
// With K replicas of n_r estimates and means m_r, the texel's mean is μ = Σ n_r m_r / N (N = Σ n_r). The replica
// means are independent (independent scrambles), each unbiased, with variance σ_r² ∝ 1/n_r for Monte Carlo and
// smaller for stratified points; for equal counts the unbiased estimate of Var(μ) = Var(m_r)/K is
//   s² = Σ_r (m_r − μ)² / (K (K − 1)),
// and with unequal counts (an estimate dropped, a batch cut short) each term weighs (n_r/N)²·K², which reduces to
// the same for equal n_r. It has K − 1 degrees of freedom per texel: noisy for one texel (the adaptive sampler pools
// neighbours), unbiased on average (what the error summary reports).
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

#include "bakers/lightmap/path_sampler.h"

namespace kiln::lightmap {

struct ReplicaSums {
  std::array<double, kReplicas> y{};  // sum of the luminances
  std::array<uint32_t, kReplicas> n{};

  void add(int replica, double luminance) {
    y[replica] += luminance;
    ++n[replica];
  }
  void merge(const ReplicaSums& o) {
    for (int r = 0; r < kReplicas; ++r) {
      y[r] += o.y[r];
      n[r] += o.n[r];
    }
  }
  uint64_t count() const {
    uint64_t total = 0;
    for (uint32_t c : n) total += c;
    return total;
  }
};

// The standard error of the mean luminance of all the estimates (the header's s); +∞ while some replica has none.
inline double replica_standard_error(const ReplicaSums& s) {
  const double total = static_cast<double>(s.count());
  double sum = 0;
  for (int r = 0; r < kReplicas; ++r) {
    if (s.n[r] == 0) return std::numeric_limits<double>::infinity();
    sum += s.y[r];
  }
  const double mean = sum / total;
  double ss = 0;
  for (int r = 0; r < kReplicas; ++r) {
    const double share = s.n[r] / total;
    const double d = s.y[r] / s.n[r] - mean;
    ss += share * share * d * d;
  }
  return std::sqrt(ss * kReplicas / (kReplicas - 1));
}

}  // namespace kiln::lightmap
