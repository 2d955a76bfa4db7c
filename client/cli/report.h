// What `kiln` writes and prints about a finished job: report.json and the summary of where the outputs went and
// what the bake cost.
#pragma once

#include <iosfwd>
#include <optional>
#include <string>
#include <string_view>

namespace kiln::v1 {
class JobResult;
}

namespace kiln::cli {

// The result as JSON, from its fields: job, state, cost (samples, rays, seconds, error estimate, cache hit), the
// planner's decisions and the outputs with their digests.
std::string result_json(const v1::JobResult& result);

// The text of report.json for a result whose outputs go into a folder: the server's whole report
// (BakeReport.json) if it sent one, else result_json(). nullopt when an output is itself named report.json: the bake
// wrote its own, which is saved as it is (its bytes verified against its digest like every output).
std::optional<std::string> report_json_for(const v1::JobResult& result);

// An output name the server gave is written as a file in the --out folder only if it is a plain file name: not
// empty, no '/', no NUL or other control character, not "." or "..", at most 255 bytes. Keeps a server from
// writing outside the folder.
bool is_plain_file_name(std::string_view name);

// The cost of a bake for people: "4.19 M samples, 12.3 s of baking, error estimate 3.1e-04, cache miss (baked for
// this job)". `cache_hit` is the submit's answer or the report's.
std::string cost_line(const v1::JobResult& result, bool cache_hit);

}  // namespace kiln::cli
