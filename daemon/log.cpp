#include "daemon/log.h"

#include <cstdio>
#include <ctime>
#include <mutex>

namespace kiln::daemon {

void log_line(const std::string& subject, const std::string& message) {
  static std::mutex mu;
  char stamp[32];
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  std::strftime(stamp, sizeof stamp, "%Y-%m-%dT%H:%M:%SZ", &tm);
  const std::string line = std::string(stamp) + " kilnd: " + subject + ": " + message + "\n";
  std::lock_guard lock(mu);
  std::fwrite(line.data(), 1, line.size(), stderr);
  std::fflush(stderr);
}

}  // namespace kiln::daemon
