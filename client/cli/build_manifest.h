// The build manifest of `kiln build` (kiln.build.textproto, a kiln.build.v1.Manifest in protobuf text format, see
// proto/kiln_build.proto): read, checked, and turned into plain entries with their paths resolved against the
// manifest's folder. Planning the bakes (parsing each command, expanding globs) is build_plan's.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace kiln::cli {

// What a bake must meet (kiln.build.v1.Checks); unset: not checked.
struct BakeChecks {
  std::optional<double> max_error;
  std::optional<double> max_seconds;
  bool energy_conserving = false;
  std::optional<double> max_reciprocity_error;
  std::optional<double> max_invalid_texels;
};

struct ManifestBake {
  std::string name;
  std::string origin;                // "MANIFEST:LINE:COLUMN" of the entry, for messages
  std::filesystem::path job_file;    // a job file, or empty
  std::vector<std::string> command;  // the words after `kiln bake`, or empty
  std::filesystem::path inputs;      // a glob (resolved against the manifest's folder), or empty
  std::filesystem::path output;      // resolved against the manifest's folder
  std::int32_t priority = 0;
  BakeChecks checks;
};

struct Manifest {
  std::filesystem::path file;  // as given
  std::filesystem::path dir;   // its folder, against which its paths are resolved
  std::vector<ManifestBake> bakes;
};

// The default manifest's name, looked for in the working directory when `kiln build` is given none.
inline constexpr const char* kManifestName = "kiln.build.textproto";

// Reads and checks the manifest at `path` (a folder means its kiln.build.textproto). Throws UsageError naming the
// file, line and column of what is wrong: text that is not a Manifest, a bake without a name or output, two bakes
// of one name or output folder, `inputs` without `command`, a check out of range.
Manifest read_manifest(const std::string& path);

// The words of a command, split at spaces; "..." and '...' keep spaces in a word. Throws UsageError (naming
// `origin`) for an unclosed quote.
std::vector<std::string> split_command(const std::string& command, const std::string& origin);

// A path from the manifest: absolute as written, else relative to `dir`.
std::filesystem::path resolve_path(const std::filesystem::path& dir, const std::string& path);

}  // namespace kiln::cli
