// Recognising an uploaded image by its first bytes (never by a file name): the four formats kiln reads, shared by
// the environment decoder (bakers/envmap/env_input.cpp) and the texture decoder (texture_decode.cpp).
#pragma once

#include <cstddef>
#include <string>

namespace kiln::image {

struct ImageFormat {
  const char* name;          // "openexr", "hdr", "png", "jpeg": reported to people and in results
  const char* virtual_name;  // a file name whose extension picks OpenImageIO's plugin; the bytes come from memory
  bool is_float;             // default colour space: lin_rec709 if true, srgb_texture otherwise
};

inline constexpr const char* kAcceptedImageFormats = "OpenEXR, Radiance HDR, PNG or JPEG";

// The format whose signature `bytes` start with, or nullptr.
const ImageFormat* detect_image_format(const std::string& bytes);

// The first `count` bytes in hex ("76 2f 31 01"), or "nothing": what bytes with the wrong signature start with.
std::string hex_prefix(const std::string& bytes, size_t count);

}  // namespace kiln::image
