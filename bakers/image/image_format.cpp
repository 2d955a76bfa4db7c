#include "bakers/image/image_format.h"

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

}  // namespace kiln::image
