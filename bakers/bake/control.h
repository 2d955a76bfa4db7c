// How a caller follows and stops a bake: a progress callback and a cancel flag.
#pragma once

#include <atomic>
#include <functional>

#include "bakers/bake/output.h"
#include "bakers/bake/progress.h"

namespace kiln::bake {

struct BakeControl {
  // Called as the bake advances, from its worker threads but never concurrently (the bake serialises the calls).
  std::function<void(const BakeProgress&)> progress;
  // Polled often (the material bake: before every block of at most 65 536 samples); once true the bake throws
  // BakeCancelled.
  const std::atomic<bool>* cancel = nullptr;
  // Optional: takes each output as soon as it is encoded, in the order the result would list it, so that a bake
  // need not hold all its outputs until it returns (a lightmap bake of many pages: tens of megabytes a page). A
  // baker that streams (the lightmap bake) then keeps none of them and returns its result's `outputs` empty; the
  // others return theirs as before. Called from the thread that called the bake, never concurrently. What it throws
  // ends the bake with that exception. Unset: every output is returned in the result.
  std::function<void(BakeOutput&&)> output_sink;
};

}  // namespace kiln::bake
