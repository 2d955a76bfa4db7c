#include "bakers/image/reader_bytes.h"

#include <cstring>

#include "bakers/image/exr_header.h"
#include "bakers/image/gif_header.h"
#include "bakers/image/icc_profiles.h"
#include "bakers/image/jpeg_metadata.h"
#include "bakers/image/png.h"

namespace kiln::image {

const std::string& reader_bytes(const std::string& bytes, const ImageFormat& format, const std::string& who,
                                std::string& storage) {
  if (std::strcmp(format.name, "png") == 0) check_png_chunk_lengths(bytes, who);
  if (std::strcmp(format.name, "openexr") == 0) check_exr_header(bytes, who);
  if (std::strcmp(format.name, "gif") == 0) check_gif_screen(bytes, who);
  if (std::strcmp(format.name, "jpeg") == 0) {
    storage = jpeg_without_metadata(bytes, who);
    return storage;
  }
  if (std::strcmp(format.name, "tiff") == 0 || std::strcmp(format.name, "psd") == 0) {
    storage = std::strcmp(format.name, "tiff") == 0 ? tiff_without_icc_profile(bytes) : psd_without_icc_profile(bytes);
    return storage;
  }
  return bytes;
}

}  // namespace kiln::image
