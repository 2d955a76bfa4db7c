#include "client/cli/build_summary.h"

#include <nlohmann/json.hpp>

#include <ostream>

#include "client/cli/format.h"

namespace kiln::cli {

using Status = BakeOutcome::Status;

const char* status_name(Status status) {
  switch (status) {
    case Status::baked:
      return "baked";
    case Status::cached:
      return "cached";
    case Status::failed:
      return "failed";
    case Status::error:
      return "error";
    case Status::skipped:
      return "skipped";
  }
  return "?";
}

BuildTotals totals_of(const BuildOutcome& outcome) {
  BuildTotals t;
  for (const BakeOutcome& o : outcome.bakes) {
    switch (o.status) {
      case Status::baked:
        ++t.baked;
        break;
      case Status::cached:
        ++t.cached;
        t.saved_seconds += o.bake_seconds;
        break;
      case Status::failed:
        ++t.failed;
        break;
      case Status::error:
        ++t.errors;
        break;
      case Status::skipped:
        ++t.skipped;
        break;
    }
    t.files_written += o.files.written;
    t.files_unchanged += o.files.unchanged;
  }
  return t;
}

void print_build_summary(std::ostream& out, const BuildPlan& plan, const BuildOutcome& outcome) {
  const BuildTotals t = totals_of(outcome);
  out << "kiln build: " << plan.bakes.size() << " bakes in " << format_duration(outcome.seconds) << ": " << t.baked
      << " baked, " << t.cached << " cached, " << t.failed + t.errors << " failed";
  if (t.skipped) out << ", " << t.skipped << " skipped";
  out << "\n";
  out << "  the cache saved " << format_duration(t.saved_seconds) << " of baking; " << t.files_written
      << " files written, " << t.files_unchanged << " unchanged\n";
  for (std::size_t i = 0; i < plan.bakes.size(); ++i) {
    const BakeOutcome& o = outcome.bakes[i];
    if (o.status == Status::failed || o.status == Status::error) {
      out << "  FAILED " << plan.bakes[i].name << ": " << o.failure << "\n";
    }
  }
  out << std::flush;
}

std::string build_json(const BuildPlan& plan, const BuildOutcome& outcome, const std::string& manifest) {
  using Json = nlohmann::ordered_json;
  const BuildTotals t = totals_of(outcome);
  Json j;
  j["manifest"] = manifest;
  j["seconds"] = outcome.seconds;
  j["bakes"] = plan.bakes.size();
  j["baked"] = t.baked;
  j["cached"] = t.cached;
  j["failed"] = t.failed;
  j["errors"] = t.errors;
  j["skipped"] = t.skipped;
  j["saved_seconds"] = t.saved_seconds;
  j["files_written"] = t.files_written;
  j["files_unchanged"] = t.files_unchanged;
  j["connection_lost"] = outcome.connection_lost;
  Json bakes = Json::array();
  for (std::size_t i = 0; i < plan.bakes.size(); ++i) {
    const PlannedBake& b = plan.bakes[i];
    const BakeOutcome& o = outcome.bakes[i];
    Json e;
    e["name"] = b.name;
    e["type"] = b.type;
    e["status"] = status_name(o.status);
    e["job_id"] = o.job_id;
    e["seconds"] = o.wall_seconds;
    e["bake_seconds"] = o.bake_seconds;
    e["error_estimate"] = o.error_estimate >= 0 ? Json(o.error_estimate) : Json(nullptr);
    e["samples"] = o.samples;
    e["output"] = b.output.string();
    e["files_written"] = o.files.written;
    e["files_unchanged"] = o.files.unchanged;
    if (!o.failure.empty()) e["failure"] = {{"type", o.failure_type}, {"message", o.failure}};
    bakes.push_back(std::move(e));
  }
  j["results"] = std::move(bakes);
  // Messages may quote bytes from the server or a file that are not UTF-8: replaced, not thrown on.
  return j.dump(2, ' ', false, Json::error_handler_t::replace) + "\n";
}

}  // namespace kiln::cli
