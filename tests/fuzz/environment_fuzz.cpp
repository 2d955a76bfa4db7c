// An environment job's image (bakers/envmap/env_input.cpp): EXR, Radiance HDR, PNG or JPEG recognised by its bytes,
// probed from the header (as the memory estimate does) and decoded. std::runtime_error for bytes that are not an
// accepted image, truncated or too large, or not 2:1.
#include <stdexcept>

#include "bakers/envmap/env_input.h"
#include "tests/fuzz/image_fuzz.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes = kiln::fuzz::bytes_of(data, size);
  try {
    kiln::envmap::probe_environment(bytes);
  } catch (const std::runtime_error&) {
  }
  try {
    kiln::envmap::decode_environment(bytes);
  } catch (const std::runtime_error&) {
  }
  return 0;
}
