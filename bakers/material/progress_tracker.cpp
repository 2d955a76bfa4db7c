#include "bakers/material/progress_tracker.h"

#include <algorithm>
#include <cmath>

#include "bakers/bake/cancelled.h"
#include "bakers/bake/progress.h"

namespace kiln::material {

void ProgressTracker::check_cancel() const {
  if (control_.cancel && control_.cancel->load(std::memory_order_relaxed)) throw bake::BakeCancelled();
}

void ProgressTracker::add_planned(double units) {
  std::lock_guard lock(mutex_);
  planned_ += units;
}

void ProgressTracker::step(const std::string& stage, double units, uint64_t samples, double planned_delta,
                           double old_error, double new_error) {
  // NaN would break the set's ordering; it sorts as the worst error instead (and the bake rejects it later).
  const auto key = [](double e) { return std::isnan(e) ? HUGE_VAL : e; };
  std::lock_guard lock(mutex_);
  done_ += units;
  planned_ += planned_delta;
  samples_ += samples;
  if (old_error >= 0 || std::isnan(old_error)) {
    const auto it = errors_.find(key(old_error));
    if (it != errors_.end()) errors_.erase(it);
  }
  if (new_error >= 0 || std::isnan(new_error)) errors_.insert(key(new_error));
  report(stage, false);
}

void ProgressTracker::finish() {
  std::lock_guard lock(mutex_);
  report("done", true);
}

uint64_t ProgressTracker::samples() const {
  std::lock_guard lock(mutex_);
  return samples_;
}

void ProgressTracker::report(const std::string& stage, bool last) {
  // Below 1 until the very end: the planned work of a progressive bake is only a forecast.
  const double f = last ? 1.0 : std::min(0.999, planned_ > 0 ? done_ / planned_ : 0.0);
  fraction_ = std::max(fraction_, f);
  if (!control_.progress) return;
  bake::BakeProgress p;
  p.fraction = fraction_;
  const double elapsed = std::chrono::duration<double>(Clock::now() - start_).count();
  p.eta_seconds = last ? 0.0 : (fraction_ > 0 ? elapsed * (1.0 - fraction_) / fraction_ : -1.0);
  p.samples = samples_;
  p.error_estimate = errors_.empty() ? 0.0 : *errors_.rbegin();
  p.stage = stage;
  control_.progress(p);
}

}  // namespace kiln::material
