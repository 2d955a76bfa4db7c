// kilnd's open-file limit: every connection is a file descriptor, so the soft RLIMIT_NOFILE must fit both
// connection bounds besides the store's own files, or accepts fail with "too many open files" long before the
// bounds are reached.
#pragma once

#include <cstdint>
#include <string>

namespace kiln::daemon {

struct Config;

// Descriptors the configuration may need at once: both connection bounds, plus a margin for the store, the job
// database, the listeners and the workers' files.
uint64_t open_files_needed(const Config& config);

// Raises the soft RLIMIT_NOFILE to `needed` if it is lower, as far as the hard limit allows. Returns a line for the
// log saying what it did (or that the hard limit is too low, and what to change), empty if the limit already fits.
std::string fit_open_file_limit(uint64_t needed);

}  // namespace kiln::daemon
