// What a long stage of a bake polls to stop early: the caller's cancel flag and the bake's deadline (its time limit).
// Polling costs an atomic load and a clock read, so a stage polls it every block of work (a few thousand texels,
// samples or triangles), which keeps every stop within a small fraction of a second.
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstddef>
#include <stdexcept>
#include <vector>

namespace kiln::bake {

// Thrown by StopCheck::check() past the deadline. The stage that catches it decides what running out of time means
// there (the lightmap bake: a set-up that did not finish is a job that cannot be baked within its limit).
class OutOfTime : public std::runtime_error {
 public:
  OutOfTime() : std::runtime_error("the bake's time limit ran out") {}
};

class StopCheck {
 public:
  using Clock = std::chrono::steady_clock;

  StopCheck() = default;  // never stops
  StopCheck(const std::atomic<bool>* cancel, Clock::time_point deadline) : cancel_(cancel), deadline_(deadline) {}

  bool cancelled() const { return cancel_ && cancel_->load(std::memory_order_relaxed); }
  bool out_of_time() const { return deadline_ != Clock::time_point::max() && Clock::now() >= deadline_; }
  bool requested() const { return cancelled() || out_of_time(); }
  // Throws BakeCancelled when cancelled (first: a cancel wins over a deadline), OutOfTime past the deadline.
  void check() const;

  Clock::time_point deadline() const { return deadline_; }

 private:
  const std::atomic<bool>* cancel_ = nullptr;
  Clock::time_point deadline_ = Clock::time_point::max();
};

// v.resize(n), polling `stop` every 2^20 elements: value-initializing gigabytes (and faulting their pages in) takes
// seconds, which a single resize would spend deaf to a cancel.
template <class T>
void resize_polled(std::vector<T>& v, size_t n, const StopCheck& stop) {
  constexpr size_t kStep = size_t{1} << 20;
  v.reserve(n);
  for (size_t size = v.size(); size < n;) {
    stop.check();
    size = std::min(n, size + kStep);
    v.resize(size);
  }
  if (v.size() > n) v.resize(n);
}

}  // namespace kiln::bake
