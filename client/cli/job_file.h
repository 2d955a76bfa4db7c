// Job files: a kiln.v1.JobSpec in protobuf text format (see client/examples/).
#pragma once

#include <optional>
#include <string>

namespace kiln::v1 {
class JobSpec;
}

namespace kiln::cli {

// Parses the text of a job file into `spec`. `label` names the file in errors. Throws UsageError
// "LABEL:LINE:COLUMN: what is wrong" (1-based) for text that is not a JobSpec, or "LABEL: ..." for a spec
// without a job.
void parse_job_text(const std::string& text, const std::string& label, v1::JobSpec& spec);

// Reads and parses a job file; "-" reads standard input. Throws UsageError for a file that cannot be read.
// `text` receives the file's text, for locate_field.
void read_job_file(const std::string& path, v1::JobSpec& spec, std::string& text);

// Where the field that a server error names ("job.material.ggx.alpha") was written in the text of a job file, as
// "LINE:COLUMN" (1-based); the nearest enclosing field written if that one was not (a value out of range because
// it was left at its default); nullopt if none of the path was written.
std::optional<std::string> locate_field(const std::string& text, const std::string& field_path);

}  // namespace kiln::cli
