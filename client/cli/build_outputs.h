// A bake's output folder as `kiln build` writes it: replaced whole and at once (a reader sees the old folder or the
// new one, never a mix), and only where something changed, so that a build tool watching the files sees no change
// after a build that changed nothing.
#pragma once

#include <filesystem>

#include "client/cli/context.h"

namespace kiln::cli {

struct FolderWrite {
  int written = 0;    // files fetched and written
  int unchanged = 0;  // files already there with the right bytes, kept as they were
};

// Makes `dir` hold `result`'s outputs and its report.json. Files already in `dir` with the digest of an output
// are kept (hard-linked into the new folder: the same inode and modification time); the rest are fetched into a new
// folder beside `dir`, which then takes its place in one rename (renameat2 RENAME_EXCHANGE). A folder that already
// holds every output is not touched at all. On any failure `dir` is left as it was and nothing of the new folder
// remains. Throws Failure (kExitServer) saying which file could not be fetched or written.
FolderWrite write_output_folder(Context& ctx, const v1::JobResult& result, const std::filesystem::path& dir);

}  // namespace kiln::cli
