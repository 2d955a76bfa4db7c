// OpenEXR decoding from memory (bakers/image/exr.cpp, through OpenImageIO): std::runtime_error for anything that is
// not a readable EXR image, whatever its header claims.
#include <stdexcept>

#include "bakers/image/exr.h"
#include "tests/fuzz/image_fuzz.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    kiln::image::decode_exr(kiln::fuzz::bytes_of(data, size));
  } catch (const std::runtime_error&) {
  }
  return 0;
}
