// Comparisons for numerical tests, with the tolerance spelled out at the call site.
#pragma once

#include <cstdint>

namespace kiln::test {

// |a − b| ≤ rel · max(|a|, |b|) + abs: relative agreement with an absolute floor for values near zero.
bool close(double a, double b, double rel, double abs = 0.0);

// Distance between two doubles in units in the last place (0 if equal, huge if of different sign or NaN).
uint64_t ulp_distance(double a, double b);

}  // namespace kiln::test
