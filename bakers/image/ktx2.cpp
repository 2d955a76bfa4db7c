// KTX 2.0 writer and reader; see ktx2.h for the subset and the layout. Every multi-byte field is little-endian
// (KTX 2.0 has no endianness field: files are always little-endian).
#include "bakers/image/ktx2.h"

#include <algorithm>
#include <bit>
#include <cstring>
#include <stdexcept>

#include "bakers/image/half.h"

namespace kiln::image {
namespace {

constexpr unsigned char kIdentifier[12] = {0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A};
constexpr uint64_t kHeaderBytes = 80;      // identifier, 9 UInt32 fields, the index (4 UInt32 + 2 UInt64)
constexpr uint64_t kLevelEntryBytes = 24;  // byteOffset, byteLength, uncompressedByteLength (UInt64 each)

// Data Format Descriptor constants (Khronos Data Format Specification, basic descriptor block).
constexpr uint32_t kDfVersion = 2;            // KHR_DF_VERSIONNUMBER_1_3
constexpr uint32_t kDfModelRgbsda = 1;        // KHR_DF_MODEL_RGBSDA
constexpr uint32_t kDfPrimariesBt709 = 1;     // KHR_DF_PRIMARIES_BT709
constexpr uint32_t kDfTransferLinear = 1;     // KHR_DF_TRANSFER_LINEAR
constexpr uint32_t kDfQualifierSigned = 0x4;  // bit 30 of the sample's first word (qualifier nibble bit 2)
constexpr uint32_t kDfQualifierFloat = 0x8;   // bit 31
constexpr uint32_t kDfQualifierExponent = 0x2;
constexpr uint32_t kChannelIds[4] = {0, 1, 2, 15};  // KHR_DF_CHANNEL_RGBSDA_RED, _GREEN, _BLUE, _ALPHA
constexpr uint32_t kSampleCount = 4;
constexpr uint32_t kDfBlockBytes = 24 + 16 * kSampleCount;
constexpr uint32_t kDfdTotalBytes = 4 + kDfBlockBytes;

struct FormatInfo {
  uint32_t vk_format;
  uint32_t channel_bytes;  // also typeSize
  uint32_t texel_bytes;
  uint32_t level_alignment;  // lcm(texel block size, 4)
};

FormatInfo info(Ktx2Image::Format format) {
  if (format == Ktx2Image::rgba32f) return {kVkFormatR32G32B32A32Sfloat, 4, 16, 16};
  return {kVkFormatR16G16B16A16Sfloat, 2, 8, 8};
}

uint64_t align_up(uint64_t x, uint64_t a) { return (x + a - 1) / a * a; }

int max_levels(int width, int height) {
  int n = 1;
  for (int m = width > height ? width : height; m > 1; m >>= 1) ++n;
  return n;
}

void append_u32(std::string& s, uint32_t v) {
  for (int i = 0; i < 4; ++i) s.push_back(static_cast<char>((v >> (8 * i)) & 0xffu));
}
void put_u32(std::string& s, uint64_t at, uint32_t v) {
  for (int i = 0; i < 4; ++i) s[at + i] = static_cast<char>((v >> (8 * i)) & 0xffu);
}
void put_u64(std::string& s, uint64_t at, uint64_t v) {
  for (int i = 0; i < 8; ++i) s[at + i] = static_cast<char>((v >> (8 * i)) & 0xffu);
}
// Callers check the bounds first.
uint32_t get_u32(const std::string& s, uint64_t at) {
  uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | static_cast<unsigned char>(s[at + i]);
  return v;
}
uint64_t get_u64(const std::string& s, uint64_t at) {
  uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | static_cast<unsigned char>(s[at + i]);
  return v;
}

bool valid_utf8(const std::string& s) {
  size_t i = 0;
  while (i < s.size()) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    size_t n = 0;
    uint32_t cp = 0;
    if (c < 0x80) {
      ++i;
      continue;
    }
    if ((c & 0xe0) == 0xc0) {
      n = 1;
      cp = c & 0x1f;
    } else if ((c & 0xf0) == 0xe0) {
      n = 2;
      cp = c & 0x0f;
    } else if ((c & 0xf8) == 0xf0) {
      n = 3;
      cp = c & 0x07;
    } else
      return false;
    if (i + n >= s.size()) return false;  // the sequence runs past the end
    for (size_t k = 1; k <= n; ++k) {
      const unsigned char d = static_cast<unsigned char>(s[i + k]);
      if ((d & 0xc0) != 0x80) return false;
      cp = (cp << 6) | (d & 0x3f);
    }
    if ((n == 1 && cp < 0x80) || (n == 2 && cp < 0x800) || (n == 3 && cp < 0x10000) || cp > 0x10ffff ||
        (cp >= 0xd800 && cp <= 0xdfff))
      return false;
    i += n + 1;
  }
  return true;
}

std::string data_format_descriptor(const FormatInfo& f) {
  std::string d;
  append_u32(d, kDfdTotalBytes);
  append_u32(d, 0);                                   // vendorId KHRONOS (17 bits) | descriptorType BASICFORMAT
  append_u32(d, kDfVersion | (kDfBlockBytes << 16));  // versionNumber | descriptorBlockSize
  append_u32(d, kDfModelRgbsda | (kDfPrimariesBt709 << 8) | (kDfTransferLinear << 16) | (0u << 24));  // straight α
  append_u32(d, 0);              // texelBlockDimension0..3: stored minus one, 1×1×1×1 block
  append_u32(d, f.texel_bytes);  // bytesPlane0 (one plane), bytesPlane1..3 = 0
  append_u32(d, 0);              // bytesPlane4..7
  const uint32_t bits = f.channel_bytes * 8;
  for (uint32_t c = 0; c < kSampleCount; ++c) {
    const uint32_t channel_type = kChannelIds[c] | ((kDfQualifierFloat | kDfQualifierSigned) << 4);
    append_u32(d, (c * bits) | ((bits - 1) << 16) | (channel_type << 24));  // bitOffset | bitLength−1 | channel
    append_u32(d, 0);                                                       // samplePosition0..3
    append_u32(d, std::bit_cast<uint32_t>(-1.0f));                          // sampleLower
    append_u32(d, std::bit_cast<uint32_t>(1.0f));                           // sampleUpper
  }
  return d;
}

[[noreturn]] void fail(const std::string& what) { throw std::runtime_error("KTX2 file rejected: " + what); }
[[noreturn]] void bad_argument(const std::string& what) { throw std::invalid_argument("encode_ktx2: " + what); }

// ---- Writing ----

void check_layout(const Ktx2Image& image) {
  const std::string max_dim = std::to_string(kKtx2MaxDimension);
  if (image.width < 1 || image.width > kKtx2MaxDimension || image.height < 1 || image.height > kKtx2MaxDimension)
    bad_argument("width × height is " + std::to_string(image.width) + " × " + std::to_string(image.height) +
                 "; both must be between 1 and " + max_dim);
  if (image.faces != 1 && image.faces != 6)
    bad_argument("faces is " + std::to_string(image.faces) + "; use 1 for a 2-D image or 6 for a cube map");
  if (image.faces == 6 && image.width != image.height)
    bad_argument("a cube map needs square faces, got " + std::to_string(image.width) + " × " +
                 std::to_string(image.height));
  const int most = max_levels(image.width, image.height);
  if (image.levels < 1 || image.levels > most)
    bad_argument("levels is " + std::to_string(image.levels) + "; a " + std::to_string(image.width) + " × " +
                 std::to_string(image.height) + " image has 1 to " + std::to_string(most) + " mip levels");
  if (image.format != Ktx2Image::rgba16f && image.format != Ktx2Image::rgba32f)
    bad_argument("format must be rgba16f or rgba32f");
}

void check_data(const Ktx2Image& image) {
  const size_t images = static_cast<size_t>(image.levels) * image.faces;
  if (image.data.size() != images)
    bad_argument("data holds " + std::to_string(image.data.size()) +
                 " images; levels × faces = " + std::to_string(images) + " are needed, at data[level * faces + face]");
  for (int level = 0; level < image.levels; ++level)
    for (int face = 0; face < image.faces; ++face) {
      const size_t want = static_cast<size_t>(image.level_width(level)) * image.level_height(level) * 4;
      if (image.image(level, face).size() != want)
        bad_argument("data for level " + std::to_string(level) + ", face " + std::to_string(face) + " has " +
                     std::to_string(image.image(level, face).size()) + " floats; RGBA " +
                     std::to_string(image.level_width(level)) + " × " + std::to_string(image.level_height(level)) +
                     " needs " + std::to_string(want));
    }
}

// The image's key/value data with "KTXwriter" added when it has none, each key checked.
std::map<std::string, std::string> key_values_to_write(const Ktx2Image& image) {
  std::map<std::string, std::string> kv = image.key_values;
  if (!kv.count("KTXwriter")) kv["KTXwriter"] = "kiln";
  for (const auto& [key, value] : kv) {
    if (key.empty()) bad_argument("a key/value entry has an empty key");
    if (const size_t nul = key.find('\0'); nul != std::string::npos)
      bad_argument("the key starting \"" + key.substr(0, nul) + "\" has a NUL byte at position " + std::to_string(nul) +
                   "; KTX2 keys end at their first NUL, so they cannot contain one");
    if (!valid_utf8(key)) bad_argument("key \"" + key + "\" is not valid UTF-8");
    if (key.rfind("\xEF\xBB\xBF", 0) == 0) bad_argument("key \"" + key + "\" starts with a byte-order mark");
  }
  return kv;
}

// The identifier and the nine UInt32 header fields; the index that follows is left to fill in.
void append_header(std::string& out, const Ktx2Image& image, const FormatInfo& f) {
  out.append(reinterpret_cast<const char*>(kIdentifier), sizeof kIdentifier);
  append_u32(out, f.vk_format);
  append_u32(out, f.channel_bytes);  // typeSize
  append_u32(out, static_cast<uint32_t>(image.width));
  append_u32(out, static_cast<uint32_t>(image.height));
  append_u32(out, 0);  // pixelDepth: not a 3-D texture
  append_u32(out, 0);  // layerCount: not an array
  append_u32(out, static_cast<uint32_t>(image.faces));
  append_u32(out, static_cast<uint32_t>(image.levels));
  append_u32(out, 0);  // supercompressionScheme: none
}

// The key/value entries, each followed by its valuePadding; returns their length.
uint64_t append_key_values(std::string& out, const std::map<std::string, std::string>& kv) {
  const uint64_t kvd_at = out.size();
  for (const auto& [key, value] : kv) {
    const uint64_t length = key.size() + 1 + value.size() + 1;
    if (length > 0xffffffffu) bad_argument("the value of key \"" + key + "\" is too long for KTX2 (4 GiB)");
    append_u32(out, static_cast<uint32_t>(length));
    out += key;
    out.push_back('\0');
    out += value;
    out.push_back('\0');
    out.append(align_up(out.size(), 4) - out.size(), '\0');  // valuePadding
  }
  const uint64_t kvd_length = out.size() - kvd_at;
  if (kvd_length > 0xffffffffu) bad_argument("the key/value data exceed 4 GiB");
  return kvd_length;
}

// One mip level (every face) after its mipPadding, and its entry in the level index at levels_at.
void append_level(std::string& out, const Ktx2Image& image, const FormatInfo& f, int level, uint64_t levels_at) {
  out.append(align_up(out.size(), f.level_alignment) - out.size(), '\0');  // mipPadding
  const uint64_t offset = out.size();
  for (int face = 0; face < image.faces; ++face) {
    const std::vector<float>& pixels = image.image(level, face);
    if (image.format == Ktx2Image::rgba32f) {
      for (float v : pixels) append_u32(out, std::bit_cast<uint32_t>(v));
    } else {
      for (float v : pixels) {
        const uint16_t h = float_to_half(v);
        out.push_back(static_cast<char>(h & 0xffu));
        out.push_back(static_cast<char>(h >> 8));
      }
    }
  }
  const uint64_t length = out.size() - offset;
  const uint64_t entry = levels_at + kLevelEntryBytes * level;
  put_u64(out, entry + 0, offset);
  put_u64(out, entry + 8, length);
  put_u64(out, entry + 16, length);  // uncompressedByteLength = byteLength without supercompression
}

// ---- Reading ----

// The header fields, as stored.
struct Header {
  uint32_t vk_format = 0, type_size = 0, width = 0, height = 0, depth = 0, layers = 0, faces = 0, levels = 0;
  uint32_t scheme = 0;
  uint64_t dfd_at = 0, dfd_length = 0, kvd_at = 0, kvd_length = 0, sgd_length = 0;
};

Header read_header(const std::string& bytes) {
  const uint64_t size = bytes.size();
  if (size < sizeof kIdentifier || std::memcmp(bytes.data(), kIdentifier, sizeof kIdentifier) != 0)
    fail(
        "it does not start with the KTX 2.0 identifier «KTX 20»\\r\\n\\x1A\\n (not a KTX2 file, or damaged in "
        "transfer)");
  if (size < kHeaderBytes)
    fail("truncated: " + std::to_string(size) + " bytes, the header alone needs " + std::to_string(kHeaderBytes));
  Header h;
  h.vk_format = get_u32(bytes, 12), h.type_size = get_u32(bytes, 16);
  h.width = get_u32(bytes, 20), h.height = get_u32(bytes, 24), h.depth = get_u32(bytes, 28);
  h.layers = get_u32(bytes, 32), h.faces = get_u32(bytes, 36), h.levels = get_u32(bytes, 40);
  h.scheme = get_u32(bytes, 44);
  h.dfd_at = get_u32(bytes, 48), h.dfd_length = get_u32(bytes, 52);
  h.kvd_at = get_u32(bytes, 56), h.kvd_length = get_u32(bytes, 60);
  h.sgd_length = get_u64(bytes, 72);
  return h;
}

Ktx2Image::Format format_of(const Header& h) {
  if (h.vk_format == kVkFormatR16G16B16A16Sfloat) return Ktx2Image::rgba16f;
  if (h.vk_format == kVkFormatR32G32B32A32Sfloat) return Ktx2Image::rgba32f;
  fail("vkFormat is " + std::to_string(h.vk_format) +
       "; kiln reads only 97 (R16G16B16A16_SFLOAT) and 109 "
       "(R32G32B32A32_SFLOAT)");
}

// The image's shape from a header kiln reads (the subset of ktx2.h), without its key/value data and pixels.
Ktx2Image image_shape(const Header& h) {
  Ktx2Image image;
  image.format = format_of(h);
  const FormatInfo f = info(image.format);
  if (h.type_size != f.channel_bytes)
    fail("typeSize is " + std::to_string(h.type_size) + " but vkFormat " + std::to_string(h.vk_format) + " needs " +
         std::to_string(f.channel_bytes));
  if (h.height == 0) fail("pixelHeight is 0 (a 1-D texture); kiln reads only 2-D images and cube maps");
  if (h.width == 0 || h.width > static_cast<uint32_t>(kKtx2MaxDimension) ||
      h.height > static_cast<uint32_t>(kKtx2MaxDimension))
    fail("pixelWidth × pixelHeight is " + std::to_string(h.width) + " × " + std::to_string(h.height) +
         "; kiln reads sizes from 1 to " + std::to_string(kKtx2MaxDimension));
  if (h.depth != 0)
    fail("pixelDepth is " + std::to_string(h.depth) + " (a 3-D texture); kiln reads only 2-D and cubes");
  if (h.layers != 0) fail("layerCount is " + std::to_string(h.layers) + " (an array texture); kiln reads no arrays");
  if (h.faces != 1 && h.faces != 6) fail("faceCount is " + std::to_string(h.faces) + "; it must be 1 or 6");
  if (h.faces == 6 && h.width != h.height)
    fail("a cube map with non-square faces (" + std::to_string(h.width) + " × " + std::to_string(h.height) + ")");
  image.width = static_cast<int>(h.width);
  image.height = static_cast<int>(h.height);
  image.faces = static_cast<int>(h.faces);
  const int most = max_levels(image.width, image.height);
  if (h.levels == 0) fail("levelCount is 0 (mipmaps to be generated at load time), which kiln does not support");
  if (h.levels > static_cast<uint32_t>(most))
    fail("levelCount is " + std::to_string(h.levels) + " but a " + std::to_string(h.width) + " × " +
         std::to_string(h.height) + " image has at most " + std::to_string(most) + " levels");
  image.levels = static_cast<int>(h.levels);
  if (h.scheme != 0)
    fail("supercompressionScheme is " + std::to_string(h.scheme) + "; kiln reads only uncompressed files (0)");
  if (h.sgd_length != 0) fail("it has supercompression global data although supercompressionScheme is 0");
  return image;
}

// The end of the level index, which must lie inside the file.
uint64_t level_index_end(const Header& h, uint64_t size) {
  const uint64_t index_end = kHeaderBytes + kLevelEntryBytes * h.levels;
  if (index_end > size)
    fail("truncated: the level index of " + std::to_string(h.levels) + " levels ends at byte " +
         std::to_string(index_end) + " but the file has " + std::to_string(size) + " bytes");
  return index_end;
}

// The basic descriptor block's words against what vkFormat needs.
void check_descriptor_block(const std::string& bytes, uint64_t b, const FormatInfo& f, uint32_t vk_format) {
  const uint32_t w0 = get_u32(bytes, b), w1 = get_u32(bytes, b + 4), w2 = get_u32(bytes, b + 8);
  if ((w0 & 0x1ffffu) != 0 || (w0 >> 17) != 0)
    fail("the first Data Format Descriptor block is not a Khronos basic descriptor block");
  if ((w1 & 0xffffu) != kDfVersion)
    fail("the Data Format Descriptor has version " + std::to_string(w1 & 0xffffu) + "; KTX2 requires 2");
  if ((w1 >> 16) != kDfBlockBytes)
    fail("the Data Format Descriptor block has " + std::to_string(w1 >> 16) + " bytes; four samples (RGBA) need " +
         std::to_string(kDfBlockBytes));
  if ((w2 & 0xffu) != kDfModelRgbsda) fail("the Data Format Descriptor's color model is not RGBSDA");
  if (((w2 >> 16) & 0xffu) != kDfTransferLinear)
    fail("the Data Format Descriptor's transfer function is not linear, which float formats require");
  if (get_u32(bytes, b + 12) != 0) fail("the Data Format Descriptor describes texel blocks larger than 1×1");
  if (get_u32(bytes, b + 16) != f.texel_bytes || get_u32(bytes, b + 20) != 0)
    fail("the Data Format Descriptor's bytesPlane0 is not " + std::to_string(f.texel_bytes) + " for vkFormat " +
         std::to_string(vk_format));
  const uint32_t bits = f.channel_bytes * 8;
  for (uint32_t c = 0; c < kSampleCount; ++c) {
    const uint32_t s = get_u32(bytes, b + 24 + 16 * c);
    const uint32_t channel = (s >> 24) & 0xfu, qualifiers = s >> 28;
    if ((s & 0xffffu) != c * bits || ((s >> 16) & 0xffu) != bits - 1 || channel != kChannelIds[c] ||
        (qualifiers & (kDfQualifierFloat | kDfQualifierSigned | kDfQualifierExponent)) !=
            (kDfQualifierFloat | kDfQualifierSigned))
      fail("Data Format Descriptor sample " + std::to_string(c) + " is not the signed float " + std::to_string(bits) +
           "-bit channel " + "RGBA"[c] + " at bit " + std::to_string(c * bits) + " that vkFormat " +
           std::to_string(vk_format) + " needs");
  }
}

// The Data Format Descriptor: its range, its size and its block.
void check_data_format_descriptor(const std::string& bytes, const Header& h, const FormatInfo& f, uint64_t index_end) {
  const uint64_t size = bytes.size();
  if (h.dfd_at < index_end || h.dfd_at % 4 != 0 || h.dfd_length > size || h.dfd_at > size - h.dfd_length)
    fail("the Data Format Descriptor (offset " + std::to_string(h.dfd_at) + ", " + std::to_string(h.dfd_length) +
         " bytes) is not a 4-aligned range after the level index inside the " + std::to_string(size) + "-byte file");
  if (h.dfd_length < kDfdTotalBytes)
    fail("the Data Format Descriptor has " + std::to_string(h.dfd_length) + " bytes; an RGBA basic descriptor needs " +
         std::to_string(kDfdTotalBytes));
  if (get_u32(bytes, h.dfd_at) != h.dfd_length)
    fail("dfdTotalSize (" + std::to_string(get_u32(bytes, h.dfd_at)) + ") differs from dfdByteLength (" +
         std::to_string(h.dfd_length) + ")");
  check_descriptor_block(bytes, h.dfd_at + 4, f, h.vk_format);
}

// The key/value entries of [at, end) into image.key_values: sorted keys, NUL-terminated, padded to 4 bytes.
void read_key_values(const std::string& bytes, uint64_t at, uint64_t end, Ktx2Image& image) {
  std::string previous;
  while (at < end) {
    if (end - at < 4) fail("a key/value entry at byte " + std::to_string(at) + " is cut off");
    const uint64_t length = get_u32(bytes, at);
    if (length > end - at - 4)
      fail("the key/value entry at byte " + std::to_string(at) + " claims " + std::to_string(length) +
           " bytes, past the end of the key/value data");
    const std::string entry = bytes.substr(at + 4, length);
    const size_t nul = entry.find('\0');
    if (nul == std::string::npos || nul == 0)
      fail("the key/value entry at byte " + std::to_string(at) + " has no NUL-terminated key");
    std::string key = entry.substr(0, nul), value = entry.substr(nul + 1);
    if (!value.empty() && value.back() == '\0') value.pop_back();
    if (!valid_utf8(key)) fail("the key at byte " + std::to_string(at) + " is not valid UTF-8");
    if (!previous.empty() && key <= previous)
      fail("the key/value entries are not sorted by key (\"" + key + "\" after \"" + previous + "\")");
    previous = key;
    image.key_values.emplace(std::move(key), std::move(value));
    at = align_up(at + 4 + length, 4);
    if (at > end) fail("the padding of the last key/value entry runs past the end of the key/value data");
  }
}

// One level's pixels (every face), after checking its index entry against the image data area
// [metadata_end, bytes.size()).
void read_level(const std::string& bytes, const FormatInfo& f, int level, uint64_t metadata_end, Ktx2Image& image) {
  const uint64_t size = bytes.size();
  const uint64_t entry = kHeaderBytes + kLevelEntryBytes * level;
  const uint64_t offset = get_u64(bytes, entry), length = get_u64(bytes, entry + 8);
  const uint64_t uncompressed = get_u64(bytes, entry + 16);
  const uint64_t w = static_cast<uint64_t>(image.level_width(level)), h = image.level_height(level);
  const uint64_t face_bytes = w * h * f.texel_bytes, want = face_bytes * image.faces;
  const std::string which = "level " + std::to_string(level) + " ";
  if (length != want)
    fail(which + "has byteLength " + std::to_string(length) + "; " + std::to_string(image.faces) + " face(s) of " +
         std::to_string(w) + " × " + std::to_string(h) + " texels need " + std::to_string(want));
  if (uncompressed != length)
    fail(which + "has uncompressedByteLength " + std::to_string(uncompressed) + " ≠ byteLength " +
         std::to_string(length) + " although the file is not supercompressed");
  if (offset % f.level_alignment != 0)
    fail(which + "starts at byte " + std::to_string(offset) + ", not a multiple of " +
         std::to_string(f.level_alignment) + " as the specification requires for this format");
  if (offset < metadata_end || offset > size || length > size - offset)
    fail(which + "(bytes " + std::to_string(offset) + " to " + std::to_string(offset + length) +
         ") lies outside the image data area (bytes " + std::to_string(metadata_end) + " to " + std::to_string(size) +
         ")");
  for (int face = 0; face < image.faces; ++face) {
    std::vector<float>& pixels = image.image(level, face);
    pixels.resize(w * h * 4);
    const uint64_t base = offset + face_bytes * face;
    if (image.format == Ktx2Image::rgba32f) {
      for (size_t i = 0; i < pixels.size(); ++i) pixels[i] = std::bit_cast<float>(get_u32(bytes, base + 4 * i));
    } else {
      for (size_t i = 0; i < pixels.size(); ++i) {
        const uint16_t v = static_cast<uint16_t>(static_cast<unsigned char>(bytes[base + 2 * i]) |
                                                 (static_cast<unsigned char>(bytes[base + 2 * i + 1]) << 8));
        pixels[i] = half_to_float(v);
      }
    }
  }
}

}  // namespace

std::string encode_ktx2(const Ktx2Image& image) {
  check_layout(image);
  check_data(image);
  const std::map<std::string, std::string> kv = key_values_to_write(image);
  const FormatInfo f = info(image.format);
  std::string out;
  out.reserve(1024);
  append_header(out, image, f);
  const uint64_t index_at = out.size();
  out.append(kHeaderBytes - index_at, '\0');  // dfd/kvd/sgd index, filled in below
  const uint64_t levels_at = out.size();
  out.append(kLevelEntryBytes * image.levels, '\0');

  const uint64_t dfd_at = out.size();  // 4-aligned: 80 + 24·levels
  out += data_format_descriptor(f);
  const uint64_t kvd_at = out.size();
  const uint64_t kvd_length = append_key_values(out, kv);

  put_u32(out, index_at + 0, static_cast<uint32_t>(dfd_at));
  put_u32(out, index_at + 4, kDfdTotalBytes);
  put_u32(out, index_at + 8, kvd_length ? static_cast<uint32_t>(kvd_at) : 0);
  put_u32(out, index_at + 12, static_cast<uint32_t>(kvd_length));
  put_u64(out, index_at + 16, 0);  // sgdByteOffset: no supercompression global data
  put_u64(out, index_at + 24, 0);  // sgdByteLength

  // Mip levels, smallest first (the specification's order, so a stream can show a coarse image early).
  for (int level = image.levels - 1; level >= 0; --level) append_level(out, image, f, level, levels_at);
  return out;
}

Ktx2Image decode_ktx2(const std::string& bytes) {
  const Header h = read_header(bytes);
  Ktx2Image image = image_shape(h);
  const FormatInfo f = info(image.format);
  const uint64_t index_end = level_index_end(h, bytes.size());
  check_data_format_descriptor(bytes, h, f, index_end);
  uint64_t metadata_end = std::max(index_end, h.dfd_at + h.dfd_length);
  if (h.kvd_length > 0) {
    const uint64_t size = bytes.size();
    if (h.kvd_at < index_end || h.kvd_at % 4 != 0 || h.kvd_length > size || h.kvd_at > size - h.kvd_length)
      fail("the key/value data (offset " + std::to_string(h.kvd_at) + ", " + std::to_string(h.kvd_length) +
           " bytes) are not a 4-aligned range after the level index inside the " + std::to_string(size) + "-byte file");
    metadata_end = std::max(metadata_end, h.kvd_at + h.kvd_length);
    read_key_values(bytes, h.kvd_at, h.kvd_at + h.kvd_length, image);
  }
  image.data.resize(static_cast<size_t>(image.levels) * image.faces);
  for (int level = 0; level < image.levels; ++level) read_level(bytes, f, level, metadata_end, image);
  return image;
}

}  // namespace kiln::image
