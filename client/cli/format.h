// Numbers, sizes and times as `kiln` prints them for people.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace kiln::cli {

// Shortest text that reads back as the same double ("0.3", "1e-05").
std::string format_number(double v);
// Seconds for people: "0.42 s", "12.3 s", "4 min 05 s", "2 h 03 min"; "?" for a negative (unknown) time.
std::string format_duration(double seconds);
// Counts with a unit prefix: "950", "12.3 k", "4.19 M", "1.07 G".
std::string format_count(std::uint64_t n);
// Bytes: "812 B", "1.2 KiB", "33.4 MiB".
std::string format_bytes(std::uint64_t n);
// A standard error: "3.1e-04"; "unknown" for a negative one.
std::string format_error(double e);
// A string quoted as a JSON string literal, for a message that names a string the server sent ("a\u0001b").
// Messages keep this escaping (\u0008 rather than nlohmann::json's \b); report.json is written by nlohmann::json.
std::string json_string(std::string_view s);
// Local time of a Unix timestamp: "2026-11-22 14:03:07"; "-" for 0.
std::string format_time(double unix_seconds);
// UTC in ISO 8601 without a zone: "2026-11-22T13:03:07" (what JUnit's timestamp, an xs:dateTime, takes).
std::string format_iso_utc(double unix_seconds);

}  // namespace kiln::cli
