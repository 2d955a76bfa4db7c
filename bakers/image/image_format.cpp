#include "bakers/image/image_format.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstring>

namespace kiln::image {

const ImageFormat* detect_image_format(const std::string& bytes) {
  static const ImageFormat exr{"openexr", "kiln.exr", true};
  static const ImageFormat hdr{"hdr", "kiln.hdr", true};
  static const ImageFormat png{"png", "kiln.png", false};
  static const ImageFormat jpeg{"jpeg", "kiln.jpg", false};
  auto starts_with = [&](const char* magic, size_t n) {
    return bytes.size() >= n && std::memcmp(bytes.data(), magic, n) == 0;
  };
  if (starts_with("\x76\x2f\x31\x01", 4)) return &exr;
  if (starts_with("#?", 2)) return &hdr;  // "#?RADIANCE" or "#?RGBE"
  if (starts_with("\x89PNG\r\n\x1a\n", 8)) return &png;
  if (starts_with("\xff\xd8\xff", 3)) return &jpeg;
  return nullptr;
}

namespace {

// TGA has no signature: a header that a Truevision file could have (colour-map type 0 or 1, an image type TGA
// defines, a non-empty size, a pixel depth it allows).
bool plausible_tga(const std::string& bytes) {
  if (bytes.size() < 18) return false;
  const auto u8 = [&](size_t i) { return static_cast<unsigned char>(bytes[i]); };
  const unsigned colormap = u8(1), type = u8(2), width = u8(12) | u8(13) << 8, height = u8(14) | u8(15) << 8,
                 depth = u8(16);
  const bool known_type = type == 1 || type == 2 || type == 3 || type == 9 || type == 10 || type == 11;
  const bool known_depth = depth == 8 || depth == 15 || depth == 16 || depth == 24 || depth == 32;
  return colormap <= 1 && known_type && width > 0 && height > 0 && known_depth;
}

}  // namespace

const ImageFormat* detect_texture_format(const std::string& bytes) {
  if (const ImageFormat* f = detect_image_format(bytes)) return f;
  static const ImageFormat tiff{"tiff", "kiln.tif", false};
  static const ImageFormat bmp{"bmp", "kiln.bmp", false};
  static const ImageFormat dds{"dds", "kiln.dds", false, true};
  static const ImageFormat heif{"heif", "kiln.heic", false, true};
  static const ImageFormat sgi{"sgi", "kiln.sgi", false, true};
  static const ImageFormat psd{"psd", "kiln.psd", false, true};
  static const ImageFormat gif{"gif", "kiln.gif", false};
  static const ImageFormat webp{"webp", "kiln.webp", false};
  static const ImageFormat pnm{"pnm", "kiln.pnm", false};
  static const ImageFormat dpx{"dpx", "kiln.dpx", false};
  static const ImageFormat iff{"iff", "kiln.iff", false};
  static const ImageFormat targa{"targa", "kiln.tga", false};
  auto at = [&](size_t offset, const char* magic, size_t n) {
    return bytes.size() >= offset + n && std::memcmp(bytes.data() + offset, magic, n) == 0;
  };
  if (at(0, "II*\0", 4) || at(0, "MM\0*", 4) || at(0, "II+\0", 4) || at(0, "MM\0+", 4)) return &tiff;
  if (at(0, "DDS ", 4)) return &dds;
  if (at(0, "8BPS", 4)) return &psd;
  if (at(0, "GIF87a", 6) || at(0, "GIF89a", 6)) return &gif;
  if (at(0, "RIFF", 4) && at(8, "WEBP", 4)) return &webp;
  if (at(0, "SDPX", 4) || at(0, "XPDS", 4)) return &dpx;
  if (at(4, "ftyp", 4) && (at(8, "heic", 4) || at(8, "heix", 4) || at(8, "mif1", 4) || at(8, "msf1", 4) ||
                           at(8, "avif", 4))) {
    return &heif;
  }
  if (at(0, "\x01\xda", 2)) return &sgi;
  if (at(0, "FOR4", 4) && at(8, "CIMG", 4)) return &iff;
  if (bytes.size() >= 3 && bytes[0] == 'P' && std::strchr("123456fF", bytes[1]) && bytes[1] != '\0' &&
      std::isspace(static_cast<unsigned char>(bytes[2]))) {
    return &pnm;
  }
  if (at(0, "BM", 2)) return &bmp;  // after the four-byte signatures: two bytes match more by chance
  if (plausible_tga(bytes)) return &targa;
  return nullptr;
}

std::string hex_prefix(const std::string& bytes, size_t count) {
  std::string out;
  char buf[4];
  for (size_t i = 0; i < std::min(bytes.size(), count); ++i) {
    std::snprintf(buf, sizeof buf, "%s%02x", i ? " " : "", static_cast<unsigned char>(bytes[i]));
    out += buf;
  }
  return out.empty() ? "nothing" : out;
}

}  // namespace kiln::image
