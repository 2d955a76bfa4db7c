// PNG decoding from memory (bakers/image/png.cpp, through OpenImageIO): std::runtime_error for anything that is not
// a readable PNG image.
#include <stdexcept>

#include "bakers/image/png.h"
#include "tests/fuzz/image_fuzz.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    kiln::image::decode_png(kiln::fuzz::bytes_of(data, size));
  } catch (const std::runtime_error&) {
  }
  return 0;
}
