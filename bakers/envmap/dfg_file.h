// A DFG table as bytes, so that a table integrated once serves later processes too (dfg_cache.h keeps them as files
// in the store). The bytes name everything the table depends on (lobe, masking, size, sampling) and end with a
// checksum; decoding takes them only when they hold exactly the table asked for. A table that decodes is still
// checked against the code that would compute it (verify_dfg_sample), so a file left by an older kiln, whose
// integration differed, is recomputed rather than served.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

#include "bakers/brdf/albedo.h"
#include "bakers/envmap/dfg.h"
#include "bakers/envmap/lobe.h"

namespace kiln::envmap {

// Everything a table depends on: compute_dfg(lobe_model(lobe, masking), size, size, options).
struct DfgKey {
  EnvLobe lobe = EnvLobe::ggx;
  brdf::Masking masking = brdf::Masking::height_correlated;
  int size = 0;
  brdf::AlbedoOptions options;
};

// A file name that differs for every key ("dfg-ggx-height-correlated-64-1024x8-1.bin").
std::string dfg_file_name(const DfgKey& key);

std::string encode_dfg_table(const DfgKey& key, const DfgTable& table);
// The length of the encoded table of `key`, so that a reader can refuse a file of any other size unread.
size_t dfg_encoded_size(const DfgKey& key);

// The table the bytes hold, when they are an encoded table of exactly `key` (header, length, checksum, and every
// value finite); otherwise nullopt, with `why` (if given) saying what did not match.
std::optional<DfgTable> decode_dfg_table(std::string_view bytes, const DfgKey& key, std::string* why = nullptr);

// Recomputes `count` entries spread over the table and compares them bit for bit, every value (compute_dfg seeds each entry on
// its own, so one entry can be recomputed alone). False when any differs.
bool verify_dfg_sample(const DfgTable& table, const DfgKey& key, int count = 8);

}  // namespace kiln::envmap
