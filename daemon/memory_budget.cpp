#include "daemon/memory_budget.h"

#include <chrono>

namespace kiln::daemon {

bool MemoryBudget::reserve(uint64_t bytes, const std::function<bool()>& give_up) {
  std::unique_lock lock(mu_);
  for (;;) {
    if (held_ == 0 || used_ + bytes <= limit_) {
      used_ += bytes;
      ++held_;
      return true;
    }
    if (give_up && give_up()) return false;
    released_.wait_for(lock, std::chrono::milliseconds(100));
  }
}

void MemoryBudget::release(uint64_t bytes) {
  {
    std::lock_guard lock(mu_);
    used_ -= bytes;
    --held_;
  }
  released_.notify_all();
}

uint64_t MemoryBudget::in_use() const {
  std::lock_guard lock(mu_);
  return used_;
}

}  // namespace kiln::daemon
