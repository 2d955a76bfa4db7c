// KTX 2.0 container (Khronos KTX File Format Specification 2.0), written from the specification: uncompressed
// (supercompressionScheme 0) RGBA half or float images, 2-D or cube maps, with a full or partial mip chain and
// key/value metadata. Plain types only.
//
// What the writer produces, in file order:
//   header (80 bytes) | level index (24 bytes per level) | Data Format Descriptor | key/value data |
//   mip levels from the smallest to the largest, each preceded by zero padding to lcm(texel size, 4) bytes
//   (8 for rgba16f, 16 for rgba32f).
// The Data Format Descriptor is one Khronos basic block (version 2): color model RGBSDA, BT.709 primaries, linear
// transfer, straight alpha, and four samples R, G, B, A (channel ids 0, 1, 2, 15) at bit offsets 0, n, 2n, 3n with
// bit length n = 16 or 32, flagged float and signed, sampleLower/sampleUpper the bit patterns of −1.0f / 1.0f.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace kiln::image {

struct Ktx2Image {
  enum Format { rgba16f, rgba32f };  // VK_FORMAT_R16G16B16A16_SFLOAT (97), VK_FORMAT_R32G32B32A32_SFLOAT (109)

  int width = 0, height = 0;  // of level 0, in pixels
  int faces = 1;              // 1 (2-D image) or 6 (cube map: +X, −X, +Y, −Y, +Z, −Z; width must equal height)
  int levels = 1;             // 1 … floor(log2(max(width, height))) + 1
  Format format = rgba16f;
  // One image per (level, face), at data[level * faces + face]: RGBA interleaved, rows in file order (row 0 first),
  // level_width(level) × level_height(level) × 4 floats. For rgba16f the writer rounds to half (nearest, ties to
  // even; overflow to ±inf; NaN stays NaN) and the reader widens back exactly.
  std::vector<std::vector<float>> data;
  // Key/value metadata (written sorted by key, as the specification requires). Keys are non-empty UTF-8 without NUL
  // bytes. Values are stored as UTF-8 strings with a terminating NUL, as the specification asks of string values
  // such as "KTXorientation" = "rd"; the reader drops that one terminating NUL. encode_ktx2 adds "KTXwriter" =
  // "kiln" when the map has no "KTXwriter".
  std::map<std::string, std::string> key_values;

  int level_width(int level) const { return width >> level > 0 ? width >> level : 1; }
  int level_height(int level) const { return height >> level > 0 ? height >> level : 1; }
  std::vector<float>& image(int level, int face) { return data[static_cast<size_t>(level) * faces + face]; }
  const std::vector<float>& image(int level, int face) const { return data[static_cast<size_t>(level) * faces + face]; }
};

// VkFormat numbers and sizes of the two supported formats.
constexpr uint32_t kVkFormatR16G16B16A16Sfloat = 97;
constexpr uint32_t kVkFormatR32G32B32A32Sfloat = 109;

// The largest width or height either function accepts (a bound on memory, not a KTX limit).
constexpr int kKtx2MaxDimension = 16384;

// The bytes of a KTX2 file. Throws std::invalid_argument, naming the field and what is allowed, when the image is
// inconsistent (sizes, face count, level count, data sizes, keys).
std::string encode_ktx2(const Ktx2Image& image);

// Reads a KTX2 file written by encode_ktx2 or any writer of the same subset (uncompressed RGBA16F / RGBA32F, 2-D or
// cube, no array layers, no depth). Validates the identifier, the header fields, that every index entry lies inside
// the file, the Data Format Descriptor against vkFormat, the key/value entries, and every level's offset, length and
// alignment. Throws std::runtime_error, saying what is wrong and where, for anything else; never reads out of bounds.
Ktx2Image decode_ktx2(const std::string& bytes);

}  // namespace kiln::image
