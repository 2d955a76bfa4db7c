#include "tests/support/tolerance.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace kiln::test {

bool close(double a, double b, double rel, double abs) {
  if (std::isnan(a) || std::isnan(b)) return false;
  if (a == b) return true;  // also equal infinities
  return std::fabs(a - b) <= rel * std::max(std::fabs(a), std::fabs(b)) + abs;
}

uint64_t ulp_distance(double a, double b) {
  if (std::isnan(a) || std::isnan(b)) return std::numeric_limits<uint64_t>::max();
  if (a == b) return 0;
  if (std::signbit(a) != std::signbit(b)) return std::numeric_limits<uint64_t>::max();
  int64_t ia, ib;
  std::memcpy(&ia, &a, sizeof a);
  std::memcpy(&ib, &b, sizeof b);
  return static_cast<uint64_t>(ia > ib ? ia - ib : ib - ia);
}

}  // namespace kiln::test
