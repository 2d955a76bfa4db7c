// A lightmap job's uploaded texture (bakers/image/texture_decode.cpp): any bytes, recognised by their first bytes
// as PNG, JPEG, EXR, HDR, TGA, ... and decoded into the working colour space, sizes bounded from the header.
// std::runtime_error for bytes that are not an accepted image.
#include <stdexcept>

#include "bakers/image/texture_decode.h"
#include "tests/fuzz/image_fuzz.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    kiln::image::decode_texture(kiln::fuzz::bytes_of(data, size), "", "job.lightmap.textures[0]");
  } catch (const std::runtime_error&) {
  }
  return 0;
}
