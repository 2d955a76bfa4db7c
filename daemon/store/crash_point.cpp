#include "daemon/store/crash_point.h"

#include <signal.h>

#include <atomic>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <string>

namespace kiln::store {
namespace {

struct CrashTarget {
  std::string name;
  long hit = 0;  // 0: no crash point armed
  std::atomic<long> passed{0};
};

// KILND_CRASH_AT=NAME:N (N ≥ 1); anything else arms nothing.
CrashTarget& target() {
  static CrashTarget t;
  static std::once_flag once;
  std::call_once(once, [] {
    const char* spec = std::getenv("KILND_CRASH_AT");
    if (!spec) return;
    const char* colon = std::strrchr(spec, ':');
    if (!colon || colon == spec) return;
    char* end = nullptr;
    const long n = std::strtol(colon + 1, &end, 10);
    if (*end != '\0' || n < 1) return;
    t.name.assign(spec, colon);
    t.hit = n;
  });
  return t;
}

}  // namespace

void crash_point(const char* name) {
  CrashTarget& t = target();
  if (t.hit == 0 || t.name != name) return;
  if (t.passed.fetch_add(1, std::memory_order_relaxed) + 1 == t.hit) ::raise(SIGKILL);
}

}  // namespace kiln::store
