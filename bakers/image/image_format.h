// Recognising an uploaded image by its first bytes (never by a file name): the four formats the environment decoder
// reads (bakers/envmap/env_input.cpp), and the wider set the texture decoder reads (texture_decode.cpp).
#pragma once

#include <cstddef>
#include <string>

namespace kiln::image {

struct ImageFormat {
  const char* name;          // "openexr", "hdr", "png", "jpeg": reported to people and in results
  const char* virtual_name;  // a file name whose extension picks OpenImageIO's plugin; the bytes come from memory
  bool is_float;             // default colour space: lin_rec709 if true, srgb_texture otherwise
  // OpenImageIO 2.4.7 cannot read it from memory (no IOProxy support, or a broken one): the texture decoder hands
  // its reader a temporary file of the bytes.
  bool from_file = false;
};

inline constexpr const char* kAcceptedImageFormats = "OpenEXR, Radiance HDR, PNG or JPEG";

// The format whose signature `bytes` start with, or nullptr.
const ImageFormat* detect_image_format(const std::string& bytes);

// What a texture may be: the image formats OpenImageIO 2.4 reads that textures come in. Not its camera raw, DICOM,
// FITS, Cineon, Softimage, RLA, video and OpenVDB readers (no texture tool writes those, and some have no
// signature); nor, in Debian's 2.4.7, its ICO reader, which writes out of bounds on a small icon (valgrind), and
// its JPEG 2000 reader, which reads none of its own writer's files ("Expected a SOC marker").
inline constexpr const char* kAcceptedTextureFormats =
    "PNG, JPEG, OpenEXR, Radiance HDR, TGA, TIFF, BMP, DDS, PSD, GIF, WebP, HEIF, PNM, DPX, SGI or Maya IFF";

// A texture's format: detect_image_format's four, the others of kAcceptedTextureFormats by their signature, and
// TGA, which has none, by a plausible header (its reader then checks the rest); nullptr if none fits. is_float is
// set for the formats whose pixels are always floats (EXR, HDR); the others say it in their header.
const ImageFormat* detect_texture_format(const std::string& bytes);

// The first `count` bytes in hex ("76 2f 31 01"), or "nothing": what bytes with the wrong signature start with.
std::string hex_prefix(const std::string& bytes, size_t count);

}  // namespace kiln::image
