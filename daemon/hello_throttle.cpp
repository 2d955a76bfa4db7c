#include "daemon/hello_throttle.h"

#include <algorithm>

namespace kiln::daemon {

std::chrono::milliseconds HelloThrottle::failed(const std::string& address, Clock::time_point now) {
  std::lock_guard lock(mutex_);
  if (peers_.size() >= options_.max_peers && !peers_.count(address)) forget_stale(now);
  Peer& p = peers_[address];
  if (p.failures > 0 && now - p.last > options_.window) p.failures = 0;
  p.last = now;
  // Doubling stops once past the bound, so the shift never overflows however many failures pile up.
  std::chrono::milliseconds wait = options_.first;
  for (int i = 1; i < p.failures + 1 && wait < options_.most; ++i) wait *= 2;
  ++p.failures;
  return std::min(wait, options_.most);
}

std::size_t HelloThrottle::peers() const {
  std::lock_guard lock(mutex_);
  return peers_.size();
}

void HelloThrottle::forget_stale(Clock::time_point now) {
  for (auto it = peers_.begin(); it != peers_.end();) {
    it = now - it->second.last > options_.window ? peers_.erase(it) : std::next(it);
  }
  if (peers_.size() < options_.max_peers) return;
  // Every address failed recently: forget the one that failed longest ago.
  auto stalest = std::min_element(peers_.begin(), peers_.end(),
                                  [](const auto& a, const auto& b) { return a.second.last < b.second.last; });
  peers_.erase(stalest);
}

}  // namespace kiln::daemon
