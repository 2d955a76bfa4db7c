#include "bakers/scene/lightmap_file_names.h"

#include <algorithm>
#include <cctype>

namespace kiln::scene {
namespace {

bool unsafe_byte(unsigned char c) {
  if (c < 0x20 || c == 0x7f) return true;
  constexpr std::string_view kReserved = "/\\:*?\"<>|";
  return kReserved.find(static_cast<char>(c)) != std::string_view::npos;
}

// The longest prefix of `s` of at most `max` bytes that does not end inside a UTF-8 sequence.
std::string_view utf8_cut(std::string_view s, size_t max) {
  if (s.size() <= max) return s;
  size_t n = max;
  // Continuation bytes are 10xxxxxx: back up to the start of the character that straddles the cut.
  while (n > 0 && (static_cast<unsigned char>(s[n]) & 0xC0) == 0x80) --n;
  return s.substr(0, n);
}

std::string ascii_lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

}  // namespace

std::string safe_file_stem(std::string_view name) {
  std::string out(utf8_cut(name, kMaxLightmapStemBytes));
  for (char& c : out) {
    if (unsafe_byte(static_cast<unsigned char>(c))) c = '_';
  }
  if (out.empty()) return "lightmap";
  if (out.front() == '.') out.front() = '_';
  for (auto it = out.rbegin(); it != out.rend() && (*it == '.' || *it == ' '); ++it) *it = '_';
  return out;
}

const std::string& LightmapFileNames::stem(const std::string& name) {
  if (auto it = stems_.find(name); it != stems_.end()) return it->second;
  const std::string base = safe_file_stem(name);
  std::string candidate = base;
  for (int n = 2; taken_.count(ascii_lower(candidate)); ++n) {
    const std::string suffix = "-" + std::to_string(n);
    candidate = std::string(utf8_cut(base, kMaxLightmapStemBytes - suffix.size())) + suffix;
  }
  taken_.insert(ascii_lower(candidate));
  return stems_.emplace(name, candidate).first->second;
}

std::map<std::string, std::string> LightmapFileNames::renamed() const {
  std::map<std::string, std::string> out;
  for (const auto& [name, stem] : stems_) {
    if (name != stem) out.emplace(name, stem);
  }
  return out;
}

}  // namespace kiln::scene
