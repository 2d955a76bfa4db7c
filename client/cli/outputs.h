// A finished job's outputs written into the --out folder, each kept only once its bytes matched their digest, and
// the summary that says where they went and what the bake cost.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "client/cli/context.h"

namespace kiln::cli {

struct SavedFile {
  std::string name;
  std::uint64_t size = 0;
  std::string description;
};

// The --out folder, created if missing. Throws UsageError if it cannot be.
std::filesystem::path create_out_dir(const std::string& dir);

// The folder of --out, created now (so that a bad one is a usage error before anything is submitted); nullopt
// without --out.
std::optional<std::filesystem::path> out_dir_of(const Flags& f);

// Writes `bytes` aside and renames them over `path`, so that a reader never sees half a file. Throws Failure.
void write_file_atomically(const std::filesystem::path& path, const std::string& bytes);

// Output names that would leave the folder or overwrite each other are refused before anything is written: a
// Failure (kExitServer) naming the job and the name.
void check_output_names(const v1::JobResult& r);

// Fetches every output of `r` into `dir` and writes report.json. A file is only kept once its bytes matched the
// digest (the client library verifies them as they arrive; the file is written aside and renamed at the end).
std::vector<SavedFile> save_outputs(Context& ctx, const v1::JobResult& r, const std::filesystem::path& dir);

// "job ID STATE: NAME", the cost, and the outputs: those saved into `dir`, else the result's with how to fetch them.
void print_summary(Context& ctx, const v1::JobResult& r, bool cache_hit,
                   const std::optional<std::filesystem::path>& dir, const std::vector<SavedFile>& saved);

}  // namespace kiln::cli
