// The KTX2 reader (bakers/image/ktx2.cpp): documented to throw std::runtime_error for anything it does not read,
// and never to read out of bounds.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "bakers/image/ktx2.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    kiln::image::decode_ktx2(std::string(reinterpret_cast<const char*>(data), size));
  } catch (const std::runtime_error&) {
  }
  return 0;
}
