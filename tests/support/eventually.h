// Waiting for an event another thread or process causes, in tests that must pass on a slow, shared machine.
#pragma once

#include <chrono>
#include <thread>

namespace kiln::test {

// Polls `pred` every 10 ms until it holds: true then, false after `seconds`. The bound only keeps a broken build from
// hanging the suite; on a loaded machine the event may take long, and the test still passes.
template <class Pred>
bool eventually(Pred&& pred, int seconds = 300) {
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(seconds);
  while (!pred()) {
    if (std::chrono::steady_clock::now() > give_up) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

}  // namespace kiln::test
