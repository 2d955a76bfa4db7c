// CPU seconds of the whole process, every thread (getrusage): on a shared machine the figure that load inflates
// least, beside wall-clock time.
#pragma once

#include <sys/resource.h>

namespace kiln::bench {

inline double process_cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_utime.tv_sec + u.ru_stime.tv_sec + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

}  // namespace kiln::bench
