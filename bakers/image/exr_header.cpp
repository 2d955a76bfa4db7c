#include "bakers/image/exr_header.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <map>
#include <stdexcept>

namespace kiln::image {
namespace {

// What 256 scanlines (or a row of tiles) may take: OpenImageIO's read chunk and OpenEXR's largest block (DWAB).
constexpr uint64_t kMaxReadBytes = uint64_t{256} << 20;
constexpr uint64_t kScanlinesRead = 256;

int32_t little_endian_i32(const std::string& bytes, size_t at) {
  int32_t v = 0;
  std::memcpy(&v, bytes.data() + at, 4);  // little-endian, as x86 and ARM are
  return v;
}

std::string printable(const std::string& bytes, size_t at, size_t count) {
  std::string out = bytes.substr(at, std::min<size_t>(count, 64));
  for (char& c : out) {
    if (c < 32 || c > 126) c = '?';
  }
  return out;
}

// What one header says about reading its pixels.
struct ReadShape {
  int64_t width = 0;
  uint64_t pixel_bytes = 0;  // every channel's, as stored (half 2, float and uint 4)
  int64_t tile_width = 0, tile_height = 0;
};

// The channels' bytes a pixel from a "chlist" value: entries of name, NUL, pixel type (int32), linear flag and 3
// reserved bytes, x and y sampling (int32 each), ended by an empty name.
uint64_t channel_bytes(const std::string& bytes, size_t at) {
  uint64_t total = 0;
  for (size_t name_end = bytes.find('\0', at); name_end != at; name_end = bytes.find('\0', at)) {
    total += little_endian_i32(bytes, name_end + 1) == 1 ? 2 : 4;
    at = name_end + 17;
  }
  return total;
}

constexpr uint64_t kPastTheEnd = ~uint64_t{0};

// The bytes of a "chlist" value up to and with the empty name that ends it, or kPastTheEnd.
uint64_t channel_list_bytes(const std::string& bytes, size_t value) {
  for (size_t at = value; at < bytes.size();) {
    const size_t name_end = bytes.find('\0', at);
    if (name_end == std::string::npos) return kPastTheEnd;
    if (name_end == at) return at + 1 - value;
    at = name_end + 17;
  }
  return kPastTheEnd;
}

// The bytes OpenEXR 3.1 reads (and allocates) for a value of `type` whose size field says `size`. Its typed readers
// read a fixed size for the fixed types and a channel list up to its empty name, whatever the size field says, and
// the next attribute starts where they stop; a preview reads its width x height x 4 bytes, a string vector each
// entry's declared length; strings and unknown types read `size`. kPastTheEnd where it would read past `left`.
uint64_t value_bytes(const std::string& bytes, const std::string& type, size_t value, uint64_t size, uint64_t left) {
  static const std::map<std::string, uint64_t> fixed = {
      {"box2f", 16},  {"box2i", 16},    {"chromaticities", 32}, {"compression", 1}, {"deepImageState", 1},
      {"double", 8},  {"envmap", 1},    {"float", 4},           {"int", 4},         {"keycode", 28},
      {"lineOrder", 1}, {"m33d", 72},   {"m33f", 36},           {"m44d", 128},      {"m44f", 64},
      {"rational", 8}, {"tiledesc", 9}, {"timecode", 8},        {"v2d", 16},        {"v2f", 8},
      {"v2i", 8},     {"v3d", 24},      {"v3f", 12},            {"v3i", 12}};
  if (const auto it = fixed.find(type); it != fixed.end()) return it->second;
  if (type == "chlist") return channel_list_bytes(bytes, value);
  if (type == "floatvector") return size - size % 4;
  if (type == "preview") {
    if (left < 8) return kPastTheEnd;
    const uint64_t width = static_cast<uint32_t>(little_endian_i32(bytes, value));
    const uint64_t height = static_cast<uint32_t>(little_endian_i32(bytes, value + 4));
    if (width != 0 && height > (left - 8) / 4 / width) return kPastTheEnd;
    return 8 + width * height * 4;
  }
  if (type == "stringvector") {
    uint64_t read = 0;
    while (read < size) {
      if (read + 4 > left) return kPastTheEnd;
      const int32_t length = little_endian_i32(bytes, value + read);
      if (length < 0 || static_cast<uint64_t>(length) > left - read - 4) return kPastTheEnd;
      read += 4 + static_cast<uint64_t>(length);
    }
    return read;
  }
  return size;
}

// What the attribute (whose value OpenEXR reads whole within the file) says about reading the pixels.
void note_attribute(const std::string& bytes, const std::string& name, const std::string& type, size_t value,
                    ReadShape& shape) {
  if (name == "dataWindow" && type == "box2i") {
    shape.width = int64_t{little_endian_i32(bytes, value + 8)} - little_endian_i32(bytes, value) + 1;
  } else if (name == "channels" && type == "chlist") {
    shape.pixel_bytes = channel_bytes(bytes, value);
  } else if (name == "tiles" && type == "tiledesc") {
    shape.tile_width = static_cast<uint32_t>(little_endian_i32(bytes, value));
    shape.tile_height = static_cast<uint32_t>(little_endian_i32(bytes, value + 4));
  }
}

void check_read_bytes(const ReadShape& shape, size_t header_at, const std::string& who) {
  if (shape.width <= 0 || shape.pixel_bytes == 0) return;  // OpenEXR refuses such a header itself
  const uint64_t scanline = static_cast<uint64_t>(shape.width) * shape.pixel_bytes;
  const bool tiled = shape.tile_width > 0 && shape.tile_height > 0;
  // A row of tiles spans whole tiles across the width.
  const uint64_t across = tiled ? (static_cast<uint64_t>(shape.width) + shape.tile_width - 1) / shape.tile_width *
                                      shape.tile_width * shape.pixel_bytes
                                : scanline;
  const uint64_t rows = tiled ? static_cast<uint64_t>(shape.tile_height) : kScanlinesRead;
  if (across > kMaxReadBytes / rows) {
    throw std::runtime_error(
        who + ": the EXR header at byte " + std::to_string(header_at) + " declares " + std::to_string(shape.width) +
        " pixels a scanline of " + std::to_string(shape.pixel_bytes) + " bytes each" +
        (tiled ? " in tiles " + std::to_string(shape.tile_height) + " high" : std::string()) +
        ": reading them takes more than the limit of " + std::to_string(kMaxReadBytes >> 20) + " MiB for " +
        (tiled ? "a row of tiles" : std::to_string(kScanlinesRead) + " scanlines") +
        " (corrupt?); kiln reads EXR images up to 65536 RGBA float pixels wide");
  }
}

}  // namespace

void check_exr_header(const std::string& bytes, const std::string& who) {
  // After the magic number and the version field: headers of attributes (name NUL, type NUL, int32 size, value),
  // each ended by a NUL; a multi-part file (flag 0x1000) has several, ended by an empty one.
  if (bytes.size() < 8) return;
  const bool multipart = static_cast<unsigned char>(bytes[5]) & 0x10;
  size_t at = 8;
  for (bool header_empty = true;; header_empty = true) {
    const size_t header_at = at;
    ReadShape shape;
    while (at < bytes.size() && bytes[at] != '\0') {
      header_empty = false;
      const size_t name_end = bytes.find('\0', at);
      if (name_end == std::string::npos) return;
      const size_t type_end = bytes.find('\0', name_end + 1);
      if (type_end == std::string::npos || type_end + 5 > bytes.size()) return;
      const int32_t size = little_endian_i32(bytes, type_end + 1);
      const size_t value = type_end + 5;
      const uint64_t left = bytes.size() - value;
      const std::string type = bytes.substr(name_end + 1, type_end - name_end - 1);
      const uint64_t take = size < 0 ? kPastTheEnd : value_bytes(bytes, type, value, uint64_t(size), left);
      if (size < 0 || static_cast<uint64_t>(size) > left || take > left) {
        const std::string reads = take == uint64_t(size) || size < 0 ? std::string()
                                  : take == kPastTheEnd ? " (OpenEXR reads a " + type + " past the end of the file)"
                                                        : " (OpenEXR reads " + std::to_string(take) + " for a " + type + ")";
        throw std::runtime_error(who + ": the EXR header attribute \"" + printable(bytes, at, name_end - at) +
                                 "\" at byte " + std::to_string(at) + " declares a value of " + std::to_string(size) +
                                 " bytes" + reads + ", but only " + std::to_string(left) +
                                 " follow it (truncated or corrupt?); re-export the file and upload it again");
      }
      note_attribute(bytes, bytes.substr(at, name_end - at), type, value, shape);
      at = value + static_cast<size_t>(take);
    }
    check_read_bytes(shape, header_at, who);
    ++at;  // the NUL that ends this header
    if (!multipart || header_empty || at >= bytes.size()) return;
  }
}

}  // namespace kiln::image
