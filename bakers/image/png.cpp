#include "bakers/image/png.h"

#include <algorithm>
#include <stdexcept>

#include "bakers/image/oiio_memory.h"

namespace kiln::image {
namespace {

// Any name works for the plugin lookup: with an IOProxy nothing touches the file system.
constexpr const char* kVirtualName = "kiln-memory.png";
// A header may claim any size; refuse to allocate more than this many bytes (256 MiB) for one image.
constexpr uint64_t kMaxDecodedValues = uint64_t{1} << 28;

bool reserved_key(const std::string& key) {
  return key.rfind("oiio:", 0) == 0 || key == "DateTime" || key == "ResolutionUnit" || key == "XResolution" ||
         key == "YResolution";
}

// PNG keywords: 1–79 Latin-1 characters from 32–126 and 161–255, no leading, trailing or double spaces (PNG 1.2
// §4.2.3); kept to printable ASCII here.
bool valid_keyword(const std::string& key) {
  if (key.empty() || key.size() > 79 || key.front() == ' ' || key.back() == ' ') return false;
  if (key.find("  ") != std::string::npos) return false;
  return std::all_of(key.begin(), key.end(), [](char c) { return c >= 32 && c <= 126; });
}

void check_image(const Png8Image& image) {
  if (image.width < 1 || image.height < 1 || image.channels < 1 || image.channels > 4) {
    throw std::invalid_argument("encode_png: width and height must be at least 1 and channels 1 to 4, got " +
                                std::to_string(image.width) + "x" + std::to_string(image.height) + "x" +
                                std::to_string(image.channels));
  }
  const uint64_t expected =
      static_cast<uint64_t>(image.width) * static_cast<uint64_t>(image.height) * static_cast<uint64_t>(image.channels);
  if (image.pixels.size() != expected) {
    throw std::invalid_argument("encode_png: pixels holds " + std::to_string(image.pixels.size()) + " bytes, but a " +
                                std::to_string(image.width) + "x" + std::to_string(image.height) + " image with " +
                                std::to_string(image.channels) + " channels needs " + std::to_string(expected));
  }
  for (const auto& [key, value] : image.metadata) {
    if (reserved_key(key) || !valid_keyword(key)) {
      throw std::invalid_argument("encode_png: metadata key '" + key +
                                  "' is not usable: a PNG keyword is 1-79 printable characters, and oiio:*, "
                                  "DateTime and the resolution keys are reserved; choose another name");
    }
  }
}

uint32_t big_endian_u32(const std::string& bytes, size_t at) {
  uint32_t v = 0;
  for (size_t i = 0; i < 4; ++i) v = v << 8 | static_cast<unsigned char>(bytes[at + i]);
  return v;
}

}  // namespace

void check_png_chunk_lengths(const std::string& bytes, const std::string& who) {
  // Each chunk: length (4 bytes, big-endian, at most 2^31 - 1), type (4), data (length), CRC (4). A chunk header
  // cut short is left to libpng, which reports the truncation without allocating.
  for (size_t at = 8; at + 8 <= bytes.size();) {
    const uint64_t length = big_endian_u32(bytes, at);
    std::string type = bytes.substr(at + 4, 4);
    for (char& c : type) {
      if (c < 32 || c > 126) c = '?';
    }
    const uint64_t follow = bytes.size() - at - 8;  // its data and CRC, if the file is whole
    if (length > 0x7fffffffu || length + 4 > follow) {
      throw std::runtime_error(who + ": the PNG chunk \"" + type + "\" at byte " + std::to_string(at) + " declares " +
                               std::to_string(length) + " bytes of data, but only " +
                               std::to_string(follow >= 4 ? follow - 4 : 0) +
                               " follow it (truncated or corrupt?); re-export the file and upload it again");
    }
    if (type == "IEND") return;
    at += 12 + length;
  }
}

std::string encode_png(const Png8Image& image) {
  check_image(image);
  OIIO::ImageSpec spec(image.width, image.height, image.channels, OIIO::TypeDesc::UINT8);
  if (image.channels == 2 || image.channels == 4) spec.alpha_channel = image.channels - 1;
  // Marks the file as sRGB (an sRGB chunk), which is what display-encoded previews are.
  spec.attribute("oiio:ColorSpace", "sRGB");
  for (const auto& [key, value] : image.metadata) spec.attribute(key, value);

  // Small images: one thread, the caller owns the thread budget.
  return detail::write_to_memory(kVirtualName, spec, OIIO::TypeDesc::UINT8, image.pixels.data(), "encode_png", "PNG",
                                 "PNG");
}

Png8Image decode_png(const std::string& bytes) {
  static constexpr unsigned char kMagic[8] = {0x89, 'P', 'N', 'G', 0x0d, 0x0a, 0x1a, 0x0a};
  if (bytes.size() < 8 || !std::equal(kMagic, kMagic + 8, reinterpret_cast<const unsigned char*>(bytes.data()))) {
    throw std::runtime_error("decode_png: the " + std::to_string(bytes.size()) +
                             " bytes are not a PNG image (a PNG file starts with 89 50 4e 47 0d 0a 1a 0a)");
  }
  check_png_chunk_lengths(bytes, "decode_png");
  detail::BoundedMemReader proxy(bytes.data(), bytes.size());
  std::unique_ptr<OIIO::ImageInput> in = detail::open_or_throw(kVirtualName, proxy, bytes.size(), "decode_png", "PNG");
  const OIIO::ImageSpec& spec = in->spec();
  const uint64_t values =
      static_cast<uint64_t>(std::max(0, spec.width)) * std::max(0, spec.height) * std::max(0, spec.nchannels);
  detail::check_decoded_values(spec, values, kMaxDecodedValues, "decode_png");
  Png8Image image;
  image.width = spec.width;
  image.height = spec.height;
  image.channels = spec.nchannels;
  image.pixels.resize(values);
  detail::read_pixels(*in, OIIO::TypeDesc::UINT8, image.pixels.data(), "decode_png", "PNG");
  for (const auto& [name, value] : detail::string_attributes(spec)) {
    if (reserved_key(name)) continue;
    // OpenImageIO reads the PNG keyword "Description" as its own "ImageDescription": give back the keyword.
    image.metadata[name == "ImageDescription" ? "Description" : name] = value;
  }
  in->close();
  return image;
}

}  // namespace kiln::image
