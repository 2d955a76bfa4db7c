// Job files (client/cli/job_file.cpp): protobuf text format parsed into a kiln.v1.JobSpec, then locate_field, which
// maps a server's field path back to a line and column of the text. An input holding a NUL byte is split there:
// the text before it, a field path after it (server errors are untrusted too); otherwise a few fixed paths are looked
// up. Errors must be UsageError, never a crash.
#include <cstddef>
#include <cstdint>
#include <string>

#include "client/cli/args.h"
#include "client/cli/job_file.h"
#include "proto/kiln.pb.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string input(reinterpret_cast<const char*>(data), size);
  const size_t nul = input.find('\0');
  const std::string text = input.substr(0, nul);
  kiln::v1::JobSpec spec;
  try {
    kiln::cli::parse_job_text(text, "fuzz.textproto", spec);
  } catch (const kiln::cli::UsageError&) {
    return 0;
  }
  if (nul != std::string::npos) {
    kiln::cli::locate_field(text, input.substr(nul + 1));
  } else {
    for (const char* path : {"job", "job.material.ggx.alpha", "job.lightmap.instances[1].transform[15]",
                             "job.lightmap.materials[0]", "job.environment.faces.digests[5].sha256"}) {
      kiln::cli::locate_field(text, path);
    }
  }
  return 0;
}
