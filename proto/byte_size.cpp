#include "proto/byte_size.h"

#include <cctype>
#include <string_view>

namespace kiln::proto {

std::optional<uint64_t> parse_byte_size(std::string_view text) {
  int shift = 0;
  if (!text.empty()) {
    constexpr std::string_view kUnits = "KMGT";
    const auto u = kUnits.find(static_cast<char>(std::toupper(static_cast<unsigned char>(text.back()))));
    if (u != std::string_view::npos) {
      shift = 10 * static_cast<int>(u + 1);
      text.remove_suffix(1);
    }
  }
  if (text.empty()) return std::nullopt;
  const uint64_t max = ((uint64_t{1} << 63) - 1) >> shift;
  uint64_t v = 0;
  for (char c : text) {
    if (c < '0' || c > '9') return std::nullopt;
    const auto digit = static_cast<uint64_t>(c - '0');
    if (v > (max - digit) / 10) return std::nullopt;
    v = 10 * v + digit;
  }
  return v << shift;
}

}  // namespace kiln::proto
