// The benchmarks' --table_out: the printed table, also written to a file for docs and notes.
#pragma once

#include <cstdio>
#include <cstring>
#include <functional>
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

// The whole main of a benchmark that prints one table: its only flag is --table_out=FILE.
inline int table_bench_main(int argc, char** argv, const char* name, const std::function<std::string()>& table) {
  std::string table_out;
  for (int i = 1; i < argc; ++i) {
    if (std::strncmp(argv[i], "--table_out=", 12) != 0) {
      std::fprintf(stderr, "usage: %s [--table_out=FILE]\n", name);
      return 2;
    }
    table_out = argv[i] + 12;
  }
  const std::string t = table();
  std::fputs(t.c_str(), stdout);
  return write_table_file(t, table_out);
}

}  // namespace kiln::bench
