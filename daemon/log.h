// Log lines for people on stderr: a timestamp, what the line is about (a job, a connection), and what happened.
#pragma once

#include <string>

namespace kiln::daemon {

// Writes "2026-11-22T01:02:03Z kilnd: SUBJECT: MESSAGE" as one line (lines from threads never interleave), with
// control characters, backslashes and bytes that are not UTF-8 in SUBJECT and MESSAGE escaped (proto::printable).
void log_line(const std::string& subject, const std::string& message);

}  // namespace kiln::daemon
