// What the decoders of uploaded images (textures, environments) do to the bytes before an OpenImageIO reader sees
// them: a PNG's chunk lengths, an EXR's header and a GIF's screen are checked (libpng, OpenEXR and OpenImageIO's
// GIF reader allocate what they claim),
// a JPEG's metadata segments are dropped and the ICC profiles of TIFF and PSD files disabled (OpenImageIO reads past
// them: jpeg_metadata.h, icc_profiles.h).
#pragma once

#include <string>

#include "bakers/image/image_format.h"

namespace kiln::image {

// The bytes to hand `format`'s reader: `bytes` themselves, or the changed copy (JPEG, TIFF, PSD), kept in `storage`.
// Throws std::runtime_error naming `who` and the chunk, attribute or segment whose declared size does not fit.
const std::string& reader_bytes(const std::string& bytes, const ImageFormat& format, const std::string& who,
                                std::string& storage);

}  // namespace kiln::image
