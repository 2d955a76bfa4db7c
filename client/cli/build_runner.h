// The runner of `kiln build`: uploads what the server lacks of the plan's inputs (asking for every digest first),
// submits the bakes (N at a time), follows them all on one connection, checks each result and writes its output
// folder, and records how each bake ended for the reports.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "client/cli/build_outputs.h"
#include "client/cli/build_plan.h"
#include "client/cli/context.h"

namespace kiln::cli {

struct BuildOptions {
  std::size_t jobs = 0;     // bakes submitted and not yet ended at a time; 0: all
  bool keep_going = false;  // submit the rest after a bake failed (without: those not yet submitted are skipped)
};

struct BakeOutcome {
  enum class Status { baked, cached, failed, error, skipped };
  Status status = Status::skipped;
  std::string job_id;
  double wall_seconds = 0;     // this build's time on it: from its submit to its folder written
  double bake_seconds = 0;     // BakeReport.seconds (for a cache hit, the original bake's)
  double error_estimate = -1;  // BakeReport.error_estimate; -1 unknown
  std::uint64_t samples = 0;
  std::string failure_type;  // "job", "submit", "outputs", "connection", "skipped" or the check ("checks.max_error")
  std::string failure;       // for people: what failed and why
  FolderWrite files;
};

struct BuildOutcome {
  std::vector<BakeOutcome> bakes;  // in the plan's order
  double seconds = 0;              // of the whole build
  bool connection_lost = false;    // the build stopped early: see the bakes' failures
};

BuildOutcome run_build(Context& ctx, const BuildPlan& plan, const BuildOptions& options);

}  // namespace kiln::cli
