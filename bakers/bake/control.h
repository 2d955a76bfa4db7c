// How a caller follows and stops a bake: a progress callback and a cancel flag.
#pragma once

#include <atomic>
#include <functional>

#include "bakers/bake/progress.h"

namespace kiln::bake {

struct BakeControl {
  // Called as the bake advances, from its worker threads but never concurrently (the bake serialises the calls).
  std::function<void(const BakeProgress&)> progress;
  // Polled often (the material bake: before every block of at most 65 536 samples); once true the bake throws
  // BakeCancelled.
  const std::atomic<bool>* cancel = nullptr;
};

}  // namespace kiln::bake
