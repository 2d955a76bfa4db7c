// Text in the protocol's string fields. protobuf requires them to be UTF-8 (a frame with other bytes in a string
// field does not parse), and what they carry comes from people and files: names with bytes of another encoding, and
// control characters that must not reach a log line or a terminal as they are. Plain C++, no protobuf.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace kiln::proto {

// True if `s` is well-formed UTF-8 (no overlong forms, surrogates or code points beyond U+10FFFF).
bool is_utf8(std::string_view s);

// `s` with every byte that is not part of a well-formed UTF-8 sequence replaced by U+FFFD (the replacement
// character); `s` itself if it is UTF-8 already.
std::string to_utf8(std::string_view s);

// The longest prefix of UTF-8 `s` of at most `max_bytes` bytes that does not cut a character in two: the protocol
// bounds names in bytes, and a cut character would make the name invalid.
std::string utf8_prefix(std::string_view s, size_t max_bytes);

// `s` for a log line or a terminal: one line, nothing a terminal acts on, and nothing lost. A backslash becomes \\,
// newline, carriage return and tab \n, \r and \t, other C0 controls, DEL and bytes that are not UTF-8 \xNN, C1
// controls (U+0080 to U+009F) \u00NN; printable UTF-8 is kept as it is.
std::string printable(std::string_view s);

}  // namespace kiln::proto
