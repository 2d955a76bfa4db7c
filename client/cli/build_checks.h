// The checks of `kiln build`: what a manifest requires of a bake (kiln.build.v1.Checks), tested against its result
// like a test's assertions. A missed check fails the bake with a message that says what was measured, the limit,
// and what to change.
#pragma once

#include <string>
#include <vector>

#include "client/cli/build_manifest.h"

namespace kiln::v1 {
class JobResult;
}

namespace kiln::cli {

struct CheckFailure {
  std::string check;    // its field in the manifest, e.g. "checks.max_error"
  std::string message;  // for people
};

// UsageError for a check that does not apply to a bake of `type` ("material", "environment", "lightmap"), e.g.
// checks.max_invalid_texels on a material.
void require_applicable(const BakeChecks& checks, const std::string& type);

// The checks `result` (SUCCEEDED, with its report) misses, in the order of kiln_build.proto.
std::vector<CheckFailure> run_checks(const BakeChecks& checks, const v1::JobResult& result);

}  // namespace kiln::cli
