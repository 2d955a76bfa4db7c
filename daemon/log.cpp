#include "daemon/log.h"

#include <cstdio>
#include <ctime>
#include <mutex>

#include "proto/text.h"

namespace kiln::daemon {

void log_line(const std::string& subject, const std::string& message) {
  static std::mutex mu;
  char stamp[32];
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  std::strftime(stamp, sizeof stamp, "%Y-%m-%dT%H:%M:%SZ", &tm);
  // Subjects and messages carry what clients sent (job names, field values): escaped, so that none can end the line
  // and forge another, or send a terminal showing the log a control sequence.
  const std::string line =
      std::string(stamp) + " kilnd: " + proto::printable(subject) + ": " + proto::printable(message) + "\n";
  std::lock_guard lock(mu);
  std::fwrite(line.data(), 1, line.size(), stderr);
  std::fflush(stderr);
}

}  // namespace kiln::daemon
