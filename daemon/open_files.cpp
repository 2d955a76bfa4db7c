#include "daemon/open_files.h"

#include <sys/resource.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "daemon/config.h"

namespace kiln::daemon {

uint64_t open_files_needed(const Config& config) {
  constexpr uint64_t kStoreAndListeners = 256;
  return uint64_t{config.max_connections} + config.max_pre_hello_connections + kStoreAndListeners;
}

std::string fit_open_file_limit(uint64_t needed) {
  rlimit limit{};
  if (::getrlimit(RLIMIT_NOFILE, &limit) != 0) {
    return std::string("cannot read the open-file limit (") + std::strerror(errno) + ")";
  }
  if (limit.rlim_cur == RLIM_INFINITY || limit.rlim_cur >= needed) return {};
  const rlim_t before = limit.rlim_cur;
  const rlim_t target = limit.rlim_max == RLIM_INFINITY ? needed : std::min<rlim_t>(needed, limit.rlim_max);
  limit.rlim_cur = target;
  if (::setrlimit(RLIMIT_NOFILE, &limit) != 0) {
    return "the open-file limit is " + std::to_string(before) + ", below the " + std::to_string(needed) +
           " the connection bounds need, and raising it failed (" + std::strerror(errno) +
           "); lower max_pre_hello_connections or raise the limit (ulimit -n, LimitNOFILE in kilnd.service)";
  }
  std::string note = "raised the open-file limit (RLIMIT_NOFILE soft) from " + std::to_string(before) + " to " +
                     std::to_string(target) + " for the connection bounds";
  if (target < needed) {
    note += "; the hard limit stops it below the " + std::to_string(needed) +
            " needed: lower max_pre_hello_connections or raise the hard limit (LimitNOFILE in kilnd.service)";
  }
  return note;
}

}  // namespace kiln::daemon
