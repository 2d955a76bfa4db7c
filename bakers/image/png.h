// PNG encoding of 8-bit display images, in memory (the environment preview, and any picture meant for a person).
// Plain types only: OpenImageIO stays inside png.cpp.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace kiln::image {

// 8 bits per channel, already display-encoded (e.g. sRGB): the values are written as they are.
struct Png8Image {
  int width = 0, height = 0, channels = 0;  // channels: 1 (grey), 2 (grey, alpha), 3 (RGB) or 4 (RGBA)
  // Interleaved, row-major, top row first: pixels[(y * width + x) * channels + c].
  std::vector<uint8_t> pixels;
  // Text chunks (tEXt): keyword → text. Keywords are 1–79 printable Latin-1 characters (the PNG specification);
  // names OpenImageIO uses for the layout ("oiio:*", "DateTime", "ResolutionUnit", "XResolution", "YResolution")
  // are reserved and rejected by encode_png.
  std::map<std::string, std::string> metadata;

  uint8_t& at(int x, int y, int c) { return pixels[(static_cast<size_t>(y) * width + x) * channels + c]; }
  uint8_t at(int x, int y, int c) const { return pixels[(static_cast<size_t>(y) * width + x) * channels + c]; }
};

// The bytes of a PNG file, 8 bits per channel, marked as sRGB (an sRGB chunk). Deterministic: no time stamp is
// written. Throws std::invalid_argument when the image is inconsistent (sizes, channels, keys),
// std::runtime_error when encoding fails.
std::string encode_png(const Png8Image& image);

// Reads a PNG file from memory as 8-bit channels (16-bit files are rounded to 8 bits), with its text chunks in
// `metadata` (by their PNG keywords, "Description" included). Throws std::runtime_error with a message for people when
// the bytes are not a readable PNG image.
Png8Image decode_png(const std::string& bytes);

// Throws std::runtime_error naming `who`, the chunk and its offset if a chunk of the PNG file `bytes` (which start
// with the PNG signature) declares more data than the file holds after it. libpng allocates a chunk's declared
// length before reading it, so without this check a 234-byte upload whose tEXt chunk claims 1.8 GB makes the
// decoder allocate 1.8 GB. decode_png, the texture decoder and the environment decoder check every PNG so.
void check_png_chunk_lengths(const std::string& bytes, const std::string& who);

}  // namespace kiln::image
