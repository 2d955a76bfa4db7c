// The daemon's translation layer alone: a serialized kiln.v1.JobSpec (the body of a Submit) validated and
// translated into a bake, with its canonical text and cache key. Bad fields must end in InvalidField, never a crash.
// (request_fuzz reaches the same code through frames; this target spends all its time here.)
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>

#include "daemon/translate.h"
#include "proto/kiln.pb.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  kiln::v1::JobSpec spec;
  if (!spec.ParseFromArray(data, static_cast<int>(size))) return 0;
  try {
    const kiln::daemon::BakeRequest bake = kiln::daemon::translate(spec);
    kiln::daemon::canonical_text(bake);
    kiln::daemon::cache_key(bake, kiln::daemon::baker_version(bake));
  } catch (const kiln::daemon::InvalidField& e) {
    // For checking a corpus by hand: which inputs are refused, and why.
    if (std::getenv("KILN_FUZZ_VERBOSE")) std::fprintf(stderr, "refused: %s\n", e.what());
  }
  return 0;
}
