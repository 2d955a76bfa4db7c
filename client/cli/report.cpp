#include "client/cli/report.h"

#include <cmath>
#include <cstdio>

#include "client/cli/format.h"
#include "client/cli/progress.h"
#include "proto/kiln.pb.h"

namespace kiln::cli {
namespace {

// JSON has no NaN or infinity: an unknown figure is null.
std::string json_number(double v) { return std::isfinite(v) ? format_number(v) : "null"; }

}  // namespace

std::string json_string(std::string_view s) {
  std::string out = "\"";
  for (const char c : s) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(static_cast<unsigned char>(c)));
          out += buf;
        } else {
          out += c;  // UTF-8 passes through; protobuf strings are UTF-8
        }
    }
  }
  return out + "\"";
}

std::string result_json(const v1::JobResult& r) {
  const v1::BakeReport& b = r.report();
  std::string j = "{\n";
  j += "  \"job_id\": " + json_string(r.job_id()) + ",\n";
  j += "  \"name\": " + json_string(r.name()) + ",\n";
  j += "  \"state\": " + json_string(state_name(r.state())) + ",\n";
  if (r.has_error()) {
    j += "  \"error\": {\"code\": " + json_string(v1::Error::Code_Name(r.error().code())) +
         ", \"message\": " + json_string(r.error().message()) + ", \"field\": " + json_string(r.error().field()) +
         "},\n";
  }
  j += "  \"submitted_unix\": " + json_number(r.submitted_unix()) + ",\n";
  j += "  \"finished_unix\": " + json_number(r.finished_unix()) + ",\n";
  j += "  \"samples\": " + std::to_string(b.samples()) + ",\n";
  j += "  \"rays\": " + std::to_string(b.rays()) + ",\n";
  j += "  \"seconds\": " + json_number(b.seconds()) + ",\n";
  j += "  \"error_estimate\": " + json_number(b.error_estimate()) + ",\n";
  j += std::string("  \"cache_hit\": ") + (b.cache_hit() ? "true" : "false") + ",\n";
  j += "  \"baker_version\": " + json_string(b.baker_version()) + ",\n";
  j += "  \"plan\": [";
  for (int i = 0; i < b.plan_size(); ++i) {
    const auto& d = b.plan(i);
    j += std::string(i ? "," : "") + "\n    {\"effect\": " + json_string(d.effect()) +
         ", \"enabled\": " + (d.enabled() ? "true" : "false") + ", \"forced\": " + (d.forced() ? "true" : "false") +
         ", \"reason\": " + json_string(d.reason()) + "}";
  }
  j += b.plan_size() ? "\n  ],\n" : "],\n";
  j += "  \"outputs\": [";
  for (int i = 0; i < r.outputs_size(); ++i) {
    const auto& o = r.outputs(i);
    j += std::string(i ? "," : "") + "\n    {\"name\": " + json_string(o.name()) +
         ", \"media_type\": " + json_string(o.media_type()) + ", \"color_space\": " + json_string(o.color_space()) +
         ", \"sha256\": " + json_string(o.digest().sha256()) + ", \"size\": " + std::to_string(o.digest().size()) +
         ", \"description\": " + json_string(o.description()) + "}";
  }
  j += r.outputs_size() ? "\n  ]\n" : "]\n";
  return j + "}\n";
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
