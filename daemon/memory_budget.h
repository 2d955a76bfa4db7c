// The memory the running jobs may hold together (kilnd's --memory-limit). A job reserves its estimate (made from its
// spec by its baker's model, translate.h's BakeRequest::memory_bytes) before it runs and returns it when it ends; a
// reservation waits while it does not fit beside those held. Submit refuses a job larger than the whole budget, so
// every reservation fits once the others are returned.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>

namespace kiln::daemon {

class MemoryBudget {
 public:
  explicit MemoryBudget(uint64_t limit) : limit_(limit) {}

  // Blocks until `bytes` fit beside the reservations held, or `give_up` returns true (polled at least every 100 ms
  // and on every release). True when reserved. A reservation larger than the limit is granted only when nothing
  // else is held, so it runs alone rather than never.
  bool reserve(uint64_t bytes, const std::function<bool()>& give_up);
  void release(uint64_t bytes);

  uint64_t limit() const { return limit_; }
  uint64_t in_use() const;

 private:
  const uint64_t limit_;
  mutable std::mutex mu_;
  std::condition_variable released_;
  uint64_t used_ = 0;
  int held_ = 0;
};

// A reservation returned when this goes out of scope.
class MemoryReservation {
 public:
  MemoryReservation() = default;
  MemoryReservation(MemoryBudget& budget, uint64_t bytes) : budget_(&budget), bytes_(bytes) {}
  MemoryReservation(const MemoryReservation&) = delete;
  MemoryReservation& operator=(const MemoryReservation&) = delete;
  ~MemoryReservation() {
    if (budget_) budget_->release(bytes_);
  }

 private:
  MemoryBudget* budget_ = nullptr;
  uint64_t bytes_ = 0;
};

}  // namespace kiln::daemon
