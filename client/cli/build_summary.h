// What `kiln build` says when it is done: the one-screen summary on stdout (baked, cached, failed, the time the
// cache saved, each failure) and the JSON summary (--report-json) for scripts.
#pragma once

#include <iosfwd>
#include <string>

#include "client/cli/build_plan.h"
#include "client/cli/build_runner.h"

namespace kiln::cli {

struct BuildTotals {
  int baked = 0, cached = 0, failed = 0, errors = 0, skipped = 0;
  double saved_seconds = 0;  // of baking the cache hits' original bakes took
  int files_written = 0, files_unchanged = 0;
};
BuildTotals totals_of(const BuildOutcome& outcome);

void print_build_summary(std::ostream& out, const BuildPlan& plan, const BuildOutcome& outcome);

// The build as JSON: the totals, then each bake (name, type, status, job, seconds, error estimate, output folder,
// files written and unchanged, failure).
std::string build_json(const BuildPlan& plan, const BuildOutcome& outcome, const std::string& manifest);

// The status's name in reports: "baked", "cached", "failed", "error", "skipped".
const char* status_name(BakeOutcome::Status status);

}  // namespace kiln::cli
