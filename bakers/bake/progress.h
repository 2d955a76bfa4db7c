// What a running bake reports about itself, for progress bars, watchers and ETAs.
#pragma once

#include <cstdint>
#include <string>

namespace kiln::bake {

struct BakeProgress {
  double fraction = 0;        // of the planned work, in [0, 1], never decreasing; 1 only in the last call
  double eta_seconds = -1;    // remaining time estimated from the rate so far; negative while unknown
  uint64_t samples = 0;       // Monte Carlo samples taken so far
  double error_estimate = 0;  // largest estimated error among the parts estimated so far
  std::string stage;          // the baker's current stage, e.g. "tables", "validation", "encoding", "done"
};

}  // namespace kiln::bake
