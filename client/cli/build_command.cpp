// `kiln build [MANIFEST]`: reads the build manifest, plans its bakes, runs them, writes the reports and the summary.
#include <unistd.h>

#include <chrono>
#include <climits>
#include <ostream>

#include "client/cli/build_junit.h"
#include "client/cli/build_manifest.h"
#include "client/cli/build_plan.h"
#include "client/cli/build_runner.h"
#include "client/cli/build_summary.h"
#include "client/cli/outputs.h"
#include "client/cli/subcommands.h"

namespace kiln::cli {
namespace {

namespace fs = std::filesystem;

// A folder for a report file, checked before anything is baked: a typo is a usage error, not a lost report.
std::optional<fs::path> report_path(const Flags& f, const char* flag) {
  const auto v = f.get(flag);
  if (!v) return std::nullopt;
  if (v->empty()) throw UsageError(std::string(flag) + ": expected a file name, got ''");
  const fs::path path(*v);
  std::error_code ec;
  const fs::path dir = path.parent_path().empty() ? fs::path(".") : path.parent_path();
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir)) {
    throw UsageError(std::string(flag) + " " + *v + ": cannot create the folder " + dir.string() + ": " +
                     (ec ? ec.message() : "a file of that name is in the way"));
  }
  return path;
}

std::string hostname() {
  char name[HOST_NAME_MAX + 1] = {};
  if (gethostname(name, sizeof name - 1) != 0) return "localhost";
  return name;
}

double unix_now() { return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count(); }

}  // namespace

int cmd_build(Context& ctx, const Flags& f) {
  if (f.positional.size() > 1) {
    throw UsageError("unexpected argument '" + f.positional[1] + "': `kiln build` takes one manifest");
  }
  BuildOptions options;
  if (auto v = f.get("--jobs")) options.jobs = static_cast<std::size_t>(parse_whole("--jobs", *v, {1, 100000}));
  options.keep_going = f.has("--keep-going");
  const auto junit = report_path(f, "--report-junit");
  const auto json = report_path(f, "--report-json");

  const Manifest manifest = read_manifest(f.positional.empty() ? std::string(kManifestName) : f.positional[0]);
  const BuildPlan plan = plan_build(manifest, f.all("--only"), ctx.err);
  const double started = unix_now();
  const BuildOutcome outcome = run_build(ctx, plan, options);

  const std::string label = manifest.file.string();
  if (junit) write_file_atomically(*junit, junit_xml(plan, outcome, label, started, hostname()));
  if (json) write_file_atomically(*json, build_json(plan, outcome, label));
  print_build_summary(ctx.out, plan, outcome);
  if (outcome.connection_lost) return kExitServer;
  const BuildTotals t = totals_of(outcome);
  return t.failed + t.errors ? kExitJobFailed : kExitOk;
}

}  // namespace kiln::cli
