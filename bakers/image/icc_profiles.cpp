#include "bakers/image/icc_profiles.h"

#include <cstdint>
#include <algorithm>
#include <cstring>
#include <set>

namespace kiln::image {
namespace {

constexpr uint64_t kIccProfileTag = 34675;
constexpr uint64_t kIccProfileResource = 1039;
constexpr uint64_t kSignatureAt = 36;  // "acsp", 4 bytes
constexpr size_t kMaxDirectories = 1024;

// One file's layout: byte order, and classic TIFF (version 42) or BigTIFF (43).
struct Layout {
  bool little;
  int word;  // bytes of a count or an offset: 4, or 8 in BigTIFF
  int entry() const { return word == 8 ? 20 : 12; }
  int count_field() const { return word == 8 ? 8 : 2; }  // a directory's number of entries
};

// The unsigned `n`-byte number at `at` (the caller checks that it is within the bytes).
uint64_t number(const std::string& bytes, size_t at, int n, const Layout& layout) {
  uint64_t v = 0;
  for (int i = 0; i < n; ++i) {
    const uint64_t byte = static_cast<unsigned char>(bytes[at + (layout.little ? n - 1 - i : i)]);
    v = v << 8 | byte;
  }
  return v;
}

// The bytes an element of TIFF field type `type` takes, for the types libtiff reads into a byte array; 0 for others.
uint64_t element_bytes(uint64_t type) {
  switch (type) {
    case 1: case 2: case 6: case 7: return 1;  // BYTE, ASCII, SBYTE, UNDEFINED
    case 3: case 8: return 2;                  // SHORT, SSHORT
    case 4: case 9: return 4;                  // LONG, SLONG
    case 16: case 17: return 8;                // LONG8, SLONG8
    default: return 0;
  }
}

// Clears the signature of the profile that the directory entry at `at` holds, if it is an ICC profile in the file.
void clear_signature(const std::string& bytes, size_t at, const Layout& layout, std::string& out) {
  if (number(bytes, at, 2, layout) != kIccProfileTag) return;
  const uint64_t size = element_bytes(number(bytes, at + 2, 2, layout));
  const uint64_t count = number(bytes, at + 4, layout.word, layout);
  if (size == 0 || count <= kSignatureAt + 4 || count > bytes.size()) return;  // no signature to reach
  const uint64_t data = number(bytes, at + 4 + layout.word, layout.word, layout);
  if (data > bytes.size() || count * size > bytes.size() - data) return;  // libtiff refuses it
  std::memset(out.data() + data + kSignatureAt * size, 0, 4 * size);
}

// The big-endian `n`-byte number at `at`, or `fallback` past the end of the bytes.
uint64_t big_endian(const std::string& bytes, uint64_t at, int n, uint64_t fallback) {
  if (at > bytes.size() || static_cast<uint64_t>(n) > bytes.size() - at) return fallback;
  return number(bytes, at, n, Layout{false, 4});
}

}  // namespace

std::string psd_without_icc_profile(const std::string& bytes) {
  std::string out = bytes;
  constexpr uint64_t kNone = ~uint64_t{0};
  if (bytes.size() < 30 || bytes.compare(0, 4, "8BPS") != 0) return out;
  // After the 26-byte header: the colour mode data (its length, then it), then the image resources (their length,
  // then blocks of signature, id, a Pascal-string name padded to even, the data's size and the data, padded to even).
  const uint64_t resources = 26 + 4 + big_endian(bytes, 26, 4, kNone);
  const uint64_t length = big_endian(bytes, resources, 4, kNone);
  if (resources >= bytes.size() || length == kNone || length > bytes.size() - resources - 4) return out;
  const uint64_t end = resources + 4 + length;
  for (uint64_t at = resources + 4; at + 12 <= end;) {
    const uint64_t id = big_endian(bytes, at + 4, 2, kNone);
    const uint64_t name = big_endian(bytes, at + 6, 1, kNone);
    const uint64_t size_at = at + 6 + ((1 + name + 1) & ~uint64_t{1});
    const uint64_t size = big_endian(bytes, size_at, 4, kNone);
    if (size == kNone || size > end - std::min(end, size_at + 4)) return out;
    const uint64_t data = size_at + 4;
    if (id == kIccProfileResource && size > kSignatureAt + 4) std::memset(out.data() + data + kSignatureAt, 0, 4);
    at = data + ((size + 1) & ~uint64_t{1});
  }
  return out;
}

std::string tiff_without_icc_profile(const std::string& bytes) {
  std::string out = bytes;
  if (bytes.size() < 16 || (bytes[0] != 'I' && bytes[0] != 'M')) return out;
  Layout layout{bytes[0] == 'I', 4};
  const uint64_t version = number(bytes, 2, 2, layout);
  if (version != 42 && version != 43) return out;
  if (version == 43) layout.word = 8;
  uint64_t directory = number(bytes, version == 43 ? 8 : 4, layout.word, layout);
  std::set<uint64_t> seen;  // a chain of directories may loop
  while (directory != 0 && directory <= bytes.size() - layout.count_field() && seen.insert(directory).second &&
         seen.size() <= kMaxDirectories) {
    const uint64_t entries = number(bytes, directory, layout.count_field(), layout);
    const uint64_t first = directory + layout.count_field();
    if (entries > (bytes.size() - first) / layout.entry()) return out;  // libtiff refuses a directory cut short
    for (uint64_t e = 0; e < entries; ++e) clear_signature(bytes, first + e * layout.entry(), layout, out);
    const uint64_t next = first + entries * layout.entry();
    directory = next <= bytes.size() - layout.word ? number(bytes, next, layout.word, layout) : 0;
  }
  return out;
}

}  // namespace kiln::image
