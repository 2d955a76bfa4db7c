#include "client/cli/build_checks.h"

#include <nlohmann/json.hpp>

#include <cmath>

#include "client/cli/args.h"
#include "client/cli/format.h"
#include "proto/kiln.pb.h"

namespace kiln::cli {
namespace {

using Json = nlohmann::json;

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

std::string percent(double fraction) { return number(100 * fraction) + "%"; }

// The bake's whole report (BakeReport.json), or null if it sent none or it is not JSON.
Json report_of(const v1::JobResult& result) {
  if (result.report().json().empty()) return nullptr;
  return Json::parse(result.report().json(), nullptr, false);
}

// The value at `path` in `j` ("validation.energy.conserves_energy"), or null.
Json at_path(const Json& j, const std::string& path) {
  const Json* node = &j;
  std::size_t start = 0;
  while (node && start <= path.size()) {
    const std::size_t dot = path.find('.', start);
    const std::string key = path.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    if (!node->is_object() || !node->contains(key)) return nullptr;
    node = &(*node)[key];
    if (dot == std::string::npos) return *node;
    start = dot + 1;
  }
  return nullptr;
}

CheckFailure missing_figure(const char* check, const std::string& figure) {
  return {check, std::string(check) + ": the bake's report has no " + figure +
                     ", so the check cannot pass; is kilnd's baker older than this client?"};
}

void check_energy(const Json& report, std::vector<CheckFailure>& failures) {
  const Json conserves = at_path(report, "validation.energy.conserves_energy");
  if (!conserves.is_boolean()) {
    failures.push_back(missing_figure("checks.energy_conserving", "validation.energy.conserves_energy"));
    return;
  }
  if (conserves.get<bool>()) return;
  const Json e = at_path(report, "validation.energy");
  failures.push_back({"checks.energy_conserving",
                      "checks.energy_conserving: the material reflects more energy than it receives: directional "
                      "albedo up to " +
                          number(e.value("max_albedo", 0.0)) + " (std error " +
                          number(e.value("max_albedo_std_error", 0.0)) + ") at mu " +
                          number(e.value("max_albedo_mu", 0.0)) + ", white furnace up to " +
                          number(e.value("white_furnace_max_albedo", 0.0)) +
                          ", above 1 by more than 3 standard errors; fix the material's parameters"});
}

void check_reciprocity(double limit, const Json& report, std::vector<CheckFailure>& failures) {
  const Json d = at_path(report, "validation.reciprocity.max_relative_difference");
  if (!d.is_number()) {
    failures.push_back(
        missing_figure("checks.max_reciprocity_error", "validation.reciprocity.max_relative_difference"));
    return;
  }
  if (d.get<double>() <= limit) return;
  failures.push_back(
      {"checks.max_reciprocity_error", "checks.max_reciprocity_error: f(o,i) and f(i,o) differ by up to " +
                                           number(d.get<double>()) + " (relative), above the limit " + number(limit) +
                                           "; the model is not reciprocal at these parameters, or raise the limit"});
}

void check_invalid_texels(double limit, const Json& report, std::vector<CheckFailure>& failures) {
  const Json maps = at_path(report, "lightmaps");
  double texels = 0, valid = 0;
  if (maps.is_array()) {
    for (const Json& m : maps) {
      const double r = m.value("resolution", 0.0);
      texels += r * r;
      valid += m.value("valid_texels", 0.0);
    }
  }
  if (texels <= 0) {
    failures.push_back(missing_figure("checks.max_invalid_texels", "lightmaps[].resolution and valid_texels"));
    return;
  }
  const double invalid = 1 - valid / texels;
  if (invalid <= limit) return;
  failures.push_back({"checks.max_invalid_texels", "checks.max_invalid_texels: " + percent(invalid) +
                                                       " of the lightmaps' texels are invalid (" +
                                                       format_count(static_cast<std::uint64_t>(texels - valid)) +
                                                       " of " + format_count(static_cast<std::uint64_t>(texels)) +
                                                       " covered by no triangle), above the limit " + percent(limit) +
                                                       "; pack the lightmap UVs tighter, or raise the limit"});
}

}  // namespace

void require_applicable(const BakeChecks& checks, const std::string& type) {
  const auto refuse = [&](const char* check, const char* applies_to) {
    throw UsageError(std::string(check) + " applies to " + applies_to + " bakes; this one is a " + type + " bake");
  };
  if (type != "material" && checks.energy_conserving) refuse("checks.energy_conserving", "material");
  if (type != "material" && checks.max_reciprocity_error) refuse("checks.max_reciprocity_error", "material");
  if (type != "lightmap" && checks.max_invalid_texels) refuse("checks.max_invalid_texels", "lightmap");
}

std::vector<CheckFailure> run_checks(const BakeChecks& checks, const v1::JobResult& result) {
  std::vector<CheckFailure> failures;
  const v1::BakeReport& b = result.report();
  if (checks.max_error) {
    const double e = b.error_estimate();
    if (!(e >= 0) || !std::isfinite(e)) {
      failures.push_back({"checks.max_error", "checks.max_error: the bake reported no error estimate, so the limit " +
                                                  number(*checks.max_error) +
                                                  " cannot be checked; give the job a target error or more samples"});
    } else if (e > *checks.max_error) {
      failures.push_back({"checks.max_error", "checks.max_error: error estimate " + number(e) + " is above the limit " +
                                                  number(*checks.max_error) +
                                                  "; lower the job's target error (or raise its samples), or "
                                                  "raise the limit"});
    }
  }
  if (checks.max_seconds && b.seconds() > *checks.max_seconds) {
    failures.push_back({"checks.max_seconds", "checks.max_seconds: the bake took " + number(b.seconds()) +
                                                  " s, above the limit of " + number(*checks.max_seconds) +
                                                  " s; lower its quality or resolution, or raise the limit"});
  }
  if (!checks.energy_conserving && !checks.max_reciprocity_error && !checks.max_invalid_texels) return failures;
  const Json report = report_of(result);
  if (checks.energy_conserving) check_energy(report, failures);
  if (checks.max_reciprocity_error) check_reciprocity(*checks.max_reciprocity_error, report, failures);
  if (checks.max_invalid_texels) check_invalid_texels(*checks.max_invalid_texels, report, failures);
  return failures;
}

}  // namespace kiln::cli
