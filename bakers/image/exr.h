// OpenEXR encoding of float images, in memory: 32-bit float channels, lossless ZIP compression.
// Plain types only: OpenImageIO stays inside exr.cpp.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace kiln::image {

struct FloatImage {
  int width = 0, height = 0, channels = 0;
  // Interleaved, row-major, top row first: pixels[(y * width + x) * channels + c].
  std::vector<float> pixels;
  // One name per channel, in the order of `pixels`. Empty means OpenImageIO's defaults (R, G, B, A, channel4, ...).
  // A channel's meaning is its name: EXR stores channels sorted by name, and readers order them in their own ways
  // (OpenImageIO puts R, G, B, A first), so positions are not kept; find a channel with channel_index().
  std::vector<std::string> channel_names;
  // String attributes of the EXR header. "compression" and "oiio:*" are reserved for the layout, and so is
  // "kiln:channel_order" (a positional list older kiln versions wrote; dropped when read); encode_exr rejects them.
  // Bakers describe each channel under "kiln:channel.NAME".
  std::map<std::string, std::string> metadata;

  // The position of the channel called `name` in this image; throws std::out_of_range naming it and the channels
  // there are if there is none.
  int channel_index(const std::string& name) const;

  float& at(int x, int y, int c) { return pixels[(static_cast<size_t>(y) * width + x) * channels + c]; }
  float at(int x, int y, int c) const { return pixels[(static_cast<size_t>(y) * width + x) * channels + c]; }
};

// The bytes of a single-part scanline EXR file. Deterministic: the same image gives the same bytes (no time stamp
// is written unless `metadata` has a "DateTime"). Every float, NaN payloads included, is stored bit for bit.
// Throws std::invalid_argument when the image is inconsistent (sizes, names), std::runtime_error when encoding fails.
std::string encode_exr(const FloatImage& image);

// Reads an EXR file from memory into 32-bit float channels (half and uint channels are converted). The channels
// come back in OpenImageIO's order (R, G, B, A first, the rest as the file stores them, sorted by name), not
// necessarily the order encode_exr was given: read them by name (channel_index). metadata holds the header's
// string attributes except the reserved ones. Throws std::runtime_error with a message for people when the bytes
// are not a readable EXR image (not EXR at all, truncated, corrupt, or too large to decode).
FloatImage decode_exr(const std::string& bytes);

}  // namespace kiln::image
