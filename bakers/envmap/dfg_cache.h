// The environment bake's DFG tables, kept in the process: a table depends on the lobe, its masking, its size and its
// sampling (samples, replicates, seed) only, never on the environment, so a second bake of the same lobe (kilnd
// keeps its bakers in process) takes the table instead of integrating it again (0.48 s of a 256² job at the default
// 64² × 1024 samples). The same arguments give the same table, bit for bit, whether it was held or not.
#pragma once

#include <memory>

#include "bakers/brdf/albedo.h"
#include "bakers/envmap/dfg.h"
#include "bakers/envmap/lobe.h"

namespace kiln::envmap {

// Tables of at most this many entries are kept (3 MiB each), at most kDfgCacheTables of them (the oldest go
// first); larger ones are computed every time.
inline constexpr int kDfgCacheMaxEntries = 256 * 256;
inline constexpr int kDfgCacheTables = 16;

// compute_dfg(lobe_model(lobe, masking), size, size, options), from the cache when it holds it. `hit` (if given)
// says whether it did. Thread-safe.
std::shared_ptr<const DfgTable> cached_dfg(EnvLobe lobe, brdf::Masking masking, int size,
                                           const brdf::AlbedoOptions& options, bool* hit = nullptr);

}  // namespace kiln::envmap
