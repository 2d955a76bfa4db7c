// A GIF's logical screen, checked before OpenImageIO's GIF reader sees the bytes: the reader allocates a canvas of
// the screen's size (4 bytes a pixel) when it opens the file, whatever the frames hold, so a 13-byte header claiming
// 22,597 × 20,304 pixels took 1.9 GB of memory for a 118-byte upload.
#pragma once

#include <cstdint>
#include <string>

namespace kiln::image {

// The most pixels a GIF's logical screen may have: 2^26 (8192², the largest texture; a 256 MiB canvas).
inline constexpr uint64_t kMaxGifScreenPixels = uint64_t{1} << 26;

// Throws std::runtime_error naming `who` when the bytes are too short for a GIF header or the logical screen (width
// and height, little-endian 16-bit at bytes 6 to 9) has more than kMaxGifScreenPixels pixels.
void check_gif_screen(const std::string& bytes, const std::string& who);

}  // namespace kiln::image
