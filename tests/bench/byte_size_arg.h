// A benchmark's size argument in bytes: "4G", "1536M", "512MiB", "64K", "1048576" (binary units, decimals allowed).
#pragma once

#include <cstdint>
#include <cstdlib>
#include <string>

namespace kiln::bench {

inline uint64_t parse_bytes(const std::string& text) {
  char* end = nullptr;
  double n = std::strtod(text.c_str(), &end);
  const std::string unit = end ? end : "";
  if (unit == "G" || unit == "GiB") n *= 1024.0 * 1024 * 1024;
  if (unit == "M" || unit == "MiB") n *= 1024.0 * 1024;
  if (unit == "K" || unit == "KiB") n *= 1024.0;
  return static_cast<uint64_t>(n);
}

}  // namespace kiln::bench
