// Sizes in bytes as people write them on a command line or in a config file: "536870912", "512M", "4G".
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

namespace kiln::proto {

// The bytes `text` means: whole digits, optionally followed by one binary suffix K, M, G or T (either case, ×1024
// each); nullopt for anything else or a size of 2^63 or more.
std::optional<uint64_t> parse_byte_size(std::string_view text);

}  // namespace kiln::proto
