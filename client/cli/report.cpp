#include "client/cli/report.h"

#include <cmath>
#include <nlohmann/json.hpp>

#include "client/cli/format.h"
#include "client/cli/progress.h"
#include "proto/kiln.pb.h"

namespace kiln::cli {
namespace {

using Json = nlohmann::ordered_json;

// JSON has no NaN or infinity: an unknown figure is null.
Json number_or_null(double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); }

// A string as JSON; bytes that are not UTF-8 (protobuf strings are) become U+FFFD rather than an exception.
std::string dumped(const Json& v) { return v.dump(-1, ' ', false, Json::error_handler_t::replace); }

// A value on one line, objects as {"key": value, ...}: the spacing of the reports kiln has always written (the
// compact dump has none after ':' and ',').
std::string one_line(const Json& v) {
  if (!v.is_object() || v.empty()) return dumped(v);
  std::string s;
  for (const auto& item : v.items()) s += (s.empty() ? "{" : ", ") + dumped(item.key()) + ": " + one_line(item.value());
  return s + "}";
}

// An object a key a line, the entries of a non-empty array a line each.
std::string laid_out(const Json& report) {
  std::string s = "{";
  for (const auto& item : report.items()) {
    s += (s.size() == 1 ? "\n  " : ",\n  ") + dumped(item.key()) + ": ";
    const Json& value = item.value();
    if (!value.is_array() || value.empty()) {
      s += one_line(value);
      continue;
    }
    for (std::size_t i = 0; i < value.size(); ++i) s += (i ? ",\n    " : "[\n    ") + one_line(value[i]);
    s += "\n  ]";
  }
  return s + "\n}\n";
}

Json plan_json(const v1::BakeReport& b) {
  Json plan = Json::array();
  for (const auto& d : b.plan()) {
    plan.push_back({{"effect", d.effect()}, {"enabled", d.enabled()}, {"forced", d.forced()}, {"reason", d.reason()}});
  }
  return plan;
}

Json outputs_json(const v1::JobResult& r) {
  Json outputs = Json::array();
  for (const auto& o : r.outputs()) {
    outputs.push_back({{"name", o.name()},
                       {"media_type", o.media_type()},
                       {"color_space", o.color_space()},
                       {"sha256", o.digest().sha256()},
                       {"size", o.digest().size()},
                       {"description", o.description()}});
  }
  return outputs;
}

}  // namespace

std::string result_json(const v1::JobResult& r) {
  const v1::BakeReport& b = r.report();
  Json j;
  j["job_id"] = r.job_id();
  j["name"] = r.name();
  j["state"] = state_name(r.state());
  if (r.has_error()) {
    j["error"] = {{"code", v1::Error::Code_Name(r.error().code())},
                  {"message", r.error().message()},
                  {"field", r.error().field()}};
  }
  j["submitted_unix"] = number_or_null(r.submitted_unix());
  j["finished_unix"] = number_or_null(r.finished_unix());
  j["samples"] = b.samples();
  j["rays"] = b.rays();
  j["seconds"] = number_or_null(b.seconds());
  j["error_estimate"] = number_or_null(b.error_estimate());
  j["cache_hit"] = b.cache_hit();
  j["baker_version"] = b.baker_version();
  j["plan"] = plan_json(b);
  j["outputs"] = outputs_json(r);
  return laid_out(j);
}

std::optional<std::string> report_json_for(const v1::JobResult& r) {
  for (const auto& o : r.outputs()) {
    if (o.name() == "report.json") return std::nullopt;
  }
  if (!r.report().json().empty()) {
    std::string text = r.report().json();
    if (text.back() != '\n') text += '\n';
    return text;
  }
  return result_json(r);
}

bool is_plain_file_name(std::string_view name) {
  if (name.empty() || name.size() > 255 || name == "." || name == "..") return false;
  for (const char c : name) {
    if (c == '/' || static_cast<unsigned char>(c) < 0x20 || c == 0x7f) return false;
  }
  return true;
}

std::string cost_line(const v1::JobResult& r, bool cache_hit) {
  const v1::BakeReport& b = r.report();
  std::string s = format_count(b.samples()) + " samples";
  if (b.rays()) s += ", " + format_count(b.rays()) + " rays";
  s += ", " + format_duration(b.seconds()) + " of baking";
  s += ", error estimate " + format_error(b.error_estimate());
  s += cache_hit ? ", cache hit (an identical job's stored result: nothing baked now; the figures are that bake's)"
                 : ", cache miss (baked for this job)";
  return s;
}

}  // namespace kiln::cli
