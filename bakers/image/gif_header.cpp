#include "bakers/image/gif_header.h"

#include <stdexcept>

namespace kiln::image {

void check_gif_screen(const std::string& bytes, const std::string& who) {
  // "GIF87a" or "GIF89a", then the logical screen descriptor: width, height (16 bits each, little-endian), ...
  if (bytes.size() < 13) throw std::runtime_error(who + ": a GIF shorter than its 13-byte header");
  const auto u16 = [&](size_t at) {
    return static_cast<uint64_t>(static_cast<unsigned char>(bytes[at])) |
           static_cast<uint64_t>(static_cast<unsigned char>(bytes[at + 1])) << 8;
  };
  const uint64_t width = u16(6), height = u16(8);
  if (width * height > kMaxGifScreenPixels) {
    throw std::runtime_error(who + ": the GIF's screen is " + std::to_string(width) + "x" + std::to_string(height) +
                             " pixels, more than the " + std::to_string(kMaxGifScreenPixels) +
                             " an image may have; make it smaller");
  }
}

}  // namespace kiln::image
