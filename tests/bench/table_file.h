// The benchmarks' --table_out: the printed table, also written to a file for docs and notes.
#pragma once

#include <cstdio>
#include <string>

namespace kiln::bench {

// Writes `table` to `path` unless the path is empty. Returns the benchmark's exit status: 1 when the file cannot be
// written (said on stderr), else 0.
inline int write_table_file(const std::string& table, const std::string& path) {
  if (path.empty()) return 0;
  FILE* f = std::fopen(path.c_str(), "w");
  if (!f) {
    std::fprintf(stderr, "cannot write %s\n", path.c_str());
    return 1;
  }
  std::fputs(table.c_str(), f);
  std::fclose(f);
  return 0;
}

}  // namespace kiln::bench
