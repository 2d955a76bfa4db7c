#include "client/cli/build_junit.h"

#include <sstream>

#include "client/cli/build_summary.h"
#include "client/cli/format.h"

namespace kiln::cli {
namespace {

using Status = BakeOutcome::Status;

// Seconds as JUnit writes them: plain decimals, three places.
std::string seconds(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f", s < 0 ? 0.0 : s);
  return buf;
}

// What the bake cost and where its outputs went, for system-out.
std::string bake_text(const PlannedBake& b, const BakeOutcome& o) {
  std::ostringstream s;
  s << "bake " << b.name << " (" << b.type << ", " << b.origin << ")\n";
  if (!o.job_id.empty()) s << "job " << o.job_id << "\n";
  s << "status " << status_name(o.status) << "\n";
  if (o.status == Status::baked || o.status == Status::cached || o.status == Status::failed) {
    s << "error estimate " << format_error(o.error_estimate) << "\n";
    s << "baking " << format_duration(o.bake_seconds) << (o.status == Status::cached ? " (the original bake's)" : "")
      << ", " << format_count(o.samples) << " samples\n";
  }
  s << "output " << b.output.string();
  if (o.status == Status::baked || o.status == Status::cached) {
    s << " (" << o.files.written << " files written, " << o.files.unchanged << " unchanged)";
  }
  s << "\n";
  return s.str();
}

}  // namespace

std::string xml_escape(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (unsigned char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      case '\n':
      case '\t':
        out += static_cast<char>(c);
        break;
      default:
        if (c < 0x20 || c == 0x7f) {
          out += "\xEF\xBF\xBD";
        } else {
          out += static_cast<char>(c);
        }
    }
  }
  return out;
}

std::string junit_xml(const BuildPlan& plan, const BuildOutcome& outcome, const std::string& manifest,
                      double timestamp_unix, const std::string& hostname) {
  const BuildTotals t = totals_of(outcome);
  const std::string counts = " tests=\"" + std::to_string(plan.bakes.size()) + "\" failures=\"" +
                             std::to_string(t.failed) + "\" errors=\"" + std::to_string(t.errors) + "\" skipped=\"" +
                             std::to_string(t.skipped) + "\" time=\"" + seconds(outcome.seconds) + "\"";
  std::ostringstream x;
  x << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  x << "<testsuites name=\"kiln build\"" << counts << ">\n";
  x << "  <testsuite name=\"" << xml_escape(manifest) << "\" id=\"0\" package=\"kiln.build\" hostname=\""
    << xml_escape(hostname) << "\" timestamp=\"" << format_iso_utc(timestamp_unix) << "\"" << counts << ">\n";
  x << "    <properties>\n"
    << "      <property name=\"cached\" value=\"" << t.cached << "\"/>\n"
    << "      <property name=\"saved_seconds\" value=\"" << seconds(t.saved_seconds) << "\"/>\n"
    << "    </properties>\n";
  for (std::size_t i = 0; i < plan.bakes.size(); ++i) {
    const PlannedBake& b = plan.bakes[i];
    const BakeOutcome& o = outcome.bakes[i];
    x << "    <testcase name=\"" << xml_escape(b.name) << "\" classname=\"kiln.build." << b.type << "\" time=\""
      << seconds(o.wall_seconds) << "\">\n";
    const std::string message = xml_escape(o.failure);
    const std::string type = xml_escape(o.failure_type);
    switch (o.status) {
      case Status::failed:
        x << "      <failure message=\"" << message << "\" type=\"" << type << "\">" << message << "</failure>\n";
        break;
      case Status::error:
        x << "      <error message=\"" << message << "\" type=\"" << type << "\">" << message << "</error>\n";
        break;
      case Status::skipped:
        x << "      <skipped message=\"" << message << "\"/>\n";
        break;
      default:
        break;
    }
    x << "      <system-out>" << xml_escape(bake_text(b, o)) << "</system-out>\n";
    x << "    </testcase>\n";
  }
  x << "  </testsuite>\n";
  x << "</testsuites>\n";
  return x.str();
}

}  // namespace kiln::cli
