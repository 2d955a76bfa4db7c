// The material bake's progress: serialises reports from the worker threads, keeps the fraction monotone, tracks the
// largest standard error of the entries, and answers "cancelled?".
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <set>
#include <string>

#include "bakers/bake/control.h"

namespace kiln::material {

class ProgressTracker {
 public:
  using Clock = std::chrono::steady_clock;

  ProgressTracker(const bake::BakeControl& control, Clock::time_point start) : control_(control), start_(start) {}

  // Throws bake::BakeCancelled once the caller has asked to cancel.
  void check_cancel() const;
  void add_planned(double units);
  // One step done: `units` of work (samples or evaluations), `samples` of them Monte Carlo samples. When an entry's
  // error changed, pass its old and new value (-1: none, e.g. before the first estimate).
  void step(const std::string& stage, double units, uint64_t samples, double planned_delta = 0, double old_error = -1,
            double new_error = -1);
  void finish();
  uint64_t samples() const;
  const std::atomic<bool>* cancel_flag() const { return control_.cancel; }

 private:
  void report(const std::string& stage, bool last);

  const bake::BakeControl& control_;
  Clock::time_point start_;
  mutable std::mutex mutex_;
  double done_ = 0, planned_ = 0, fraction_ = 0;
  uint64_t samples_ = 0;
  std::multiset<double> errors_;
};

}  // namespace kiln::material
