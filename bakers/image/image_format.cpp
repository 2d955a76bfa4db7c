#include "bakers/image/image_format.h"

#include <algorithm>
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
