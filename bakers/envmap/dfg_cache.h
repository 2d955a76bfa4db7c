// The environment bake's DFG tables, kept in the process and, when a folder is given, in files there for later
// processes: a table depends on the lobe, its masking, its size and its sampling (samples, replicates, seed) only,
// never on the environment, so a later bake of the same lobe takes the table instead of integrating it again (0.37 s
// of a 256² job's 0.95 on 2 cores at the default 64² × 1024 samples). The same arguments give the same table, bit
// for bit, wherever it came from.
#pragma once

#include <filesystem>
#include <memory>

#include "bakers/brdf/albedo.h"
#include "bakers/envmap/dfg.h"
#include "bakers/envmap/lobe.h"

namespace kiln::envmap {

// Tables of at most this many entries are kept (3 MiB each), at most kDfgCacheTables of them in the process and
// kDfgFilesKept in the folder (the least recently used go first); larger ones are computed every time.
inline constexpr int kDfgCacheMaxEntries = 256 * 256;
inline constexpr int kDfgCacheTables = 16;
inline constexpr int kDfgFilesKept = 64;

// Where a table came from.
enum class DfgSource { computed, process, file };
const char* to_string(DfgSource source);

// Keep tables as files in `dir` too (created when first written; several processes may share it: files appear by
// rename, whole), or, with an empty path, in the process only. A file is used only when its bytes hold exactly the
// table asked for and a sample of its entries recomputes to the same bits (dfg_file.h); otherwise it is computed
// and written again.
void keep_dfg_tables_in(const std::filesystem::path& dir);

// compute_dfg(lobe_model(lobe, masking), size, size, options), from the process or the folder when either holds it.
// `source` (if given) says which. Thread-safe.
std::shared_ptr<const DfgTable> cached_dfg(EnvLobe lobe, brdf::Masking masking, int size,
                                           const brdf::AlbedoOptions& options, DfgSource* source = nullptr);

}  // namespace kiln::envmap
