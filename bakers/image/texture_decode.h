// Decoding an uploaded texture (a base-colour map of a lightmap scene) into the working colour space.
//
// Formats: the image formats OpenImageIO reads that textures come in (kAcceptedTextureFormats: PNG, JPEG, OpenEXR,
// Radiance HDR, TGA, TIFF, BMP, DDS, PSD, GIF, WebP, HEIF, PNM, DPX, SGI, Maya IFF),
// recognised by their first bytes (TGA by its header), decoded from memory where OpenImageIO 2.4 can and from a
// temporary file where it cannot; the first subimage, its top mip level. Size: at most 8192 × 8192 pixels,
// checked on the header before any pixel is read.
// Channels: one (grey) or three and more (RGB; alpha and the rest ignored). Colour space: `color_space` if given,
// else lin_rec709 for float pixels (EXR, HDR, float TIFF, ...) and srgb_texture for integer ones (PNG, JPEG, TGA,
// ...), converted with the active OpenColorIO config into its working space. Texels that are NaN, infinite or negative
// (possible only in the float formats) become 0 and are counted: a base colour outside [0, 1] cannot be a
// reflectance, so values above 1 are clamped to 1 and counted too.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "bakers/math/rgb.h"

namespace kiln::image {

inline constexpr int kMaxTextureDimension = 8192;

struct DecodedTexture {
  int width = 0, height = 0;
  std::vector<Rgb> texels;  // row-major, top row first, working space
  std::string format;       // OpenImageIO's name of the format: "png", "jpeg", "openexr", "hdr", "targa", "tiff", ...
  int64_t replaced = 0;     // texels with a channel that was NaN, infinite or negative (set to 0)
  int64_t clamped = 0;      // texels with a channel above 1 (set to 1)
};

// Throws std::runtime_error, naming `name`, for bytes that are not an accepted image, truncated files and sizes
// beyond the limit; std::invalid_argument for an unknown colour space.
DecodedTexture decode_texture(const std::string& bytes, const std::string& color_space, const std::string& name);

}  // namespace kiln::image
