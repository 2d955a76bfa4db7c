// Slows down a peer that keeps failing Hello (guessing tokens): each failure from an address within a window doubles
// the wait before its answer, up to a bound. A successful Hello is never delayed, so a right token from an address
// an attacker shares (a NAT) is served at once.
#pragma once

#include <chrono>
#include <cstddef>
#include <mutex>
#include <string>
#include <unordered_map>

namespace kiln::daemon {

class HelloThrottle {
 public:
  using Clock = std::chrono::steady_clock;
  struct Options {
    std::chrono::milliseconds first{50};   // the wait before answering the first failure
    std::chrono::milliseconds most{5000};  // the bound on any wait
    std::chrono::seconds window{60};       // failures further apart than this start the count again
    std::size_t max_peers = 4096;          // addresses remembered; past it the stalest is forgotten
  };

  HelloThrottle() : HelloThrottle(Options{}) {}
  explicit HelloThrottle(Options options) : options_(options) {}

  // Records a failed Hello from `address` at `now`; returns how long to wait before answering it:
  // first * 2^(n-1) for the n-th failure in a row within the window, at most `most`. Thread-safe.
  std::chrono::milliseconds failed(const std::string& address, Clock::time_point now = Clock::now());

  std::size_t peers() const;

 private:
  struct Peer {
    int failures = 0;
    Clock::time_point last;
  };
  void forget_stale(Clock::time_point now);

  Options options_;
  mutable std::mutex mutex_;
  std::unordered_map<std::string, Peer> peers_;
};

}  // namespace kiln::daemon
