// Job files: a kiln.v1.JobSpec in protobuf text format (see client/examples/).
#pragma once

#include <cstddef>
#include <optional>
#include <string>

namespace google::protobuf {
class Message;
}
namespace kiln::v1 {
class JobSpec;
}

namespace kiln::cli {

// Parses protobuf text format into `message`. `label` names the file in errors. Throws UsageError
// "LABEL:LINE:COLUMN: what is wrong" (1-based), pointing at the name of an unknown field rather than past it.
void parse_text_message(const std::string& text, const std::string& label, google::protobuf::Message& message);

// The text of a file written by people (a job file, a build manifest), refused beyond `max_bytes`; "-" reads
// standard input. `what` names it in errors ("job file"). Throws UsageError.
std::string read_text_file(const std::string& path, const std::string& what, std::size_t max_bytes);

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
