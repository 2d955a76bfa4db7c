#include "proto/text.h"

#include <cstdint>
#include <cstdio>

namespace kiln::proto {
namespace {

// The length of the well-formed UTF-8 sequence at s[i], or 0 if there is none (Unicode 15, table 3-7).
size_t sequence_length(std::string_view s, size_t i) {
  const auto byte = [&](size_t k) { return static_cast<uint8_t>(s[k]); };
  const uint8_t b0 = byte(i);
  if (b0 < 0x80) return 1;
  size_t n;
  uint8_t low = 0x80, high = 0xbf;  // the range of the second byte
  if (b0 >= 0xc2 && b0 <= 0xdf) {
    n = 2;
  } else if (b0 >= 0xe0 && b0 <= 0xef) {
    n = 3;
    if (b0 == 0xe0) low = 0xa0;   // overlong
    if (b0 == 0xed) high = 0x9f;  // surrogates
  } else if (b0 >= 0xf0 && b0 <= 0xf4) {
    n = 4;
    if (b0 == 0xf0) low = 0x90;   // overlong
    if (b0 == 0xf4) high = 0x8f;  // beyond U+10FFFF
  } else {
    return 0;  // a continuation byte, C0, C1 (overlong) or F5 to FF
  }
  if (i + n > s.size() || byte(i + 1) < low || byte(i + 1) > high) return 0;
  for (size_t k = 2; k < n; ++k) {
    if (byte(i + k) < 0x80 || byte(i + k) > 0xbf) return 0;
  }
  return n;
}

void append_hex(std::string& out, const char* form, unsigned value) {
  char buf[8];
  std::snprintf(buf, sizeof buf, form, value);
  out += buf;
}

}  // namespace

bool is_utf8(std::string_view s) {
  for (size_t i = 0; i < s.size();) {
    const size_t n = sequence_length(s, i);
    if (n == 0) return false;
    i += n;
  }
  return true;
}

std::string to_utf8(std::string_view s) {
  if (is_utf8(s)) return std::string(s);
  std::string out;
  out.reserve(s.size() + 8);
  for (size_t i = 0; i < s.size();) {
    const size_t n = sequence_length(s, i);
    if (n == 0) {
      out += "\xef\xbf\xbd";  // U+FFFD
      ++i;
    } else {
      out.append(s, i, n);
      i += n;
    }
  }
  return out;
}

std::string utf8_prefix(std::string_view s, size_t max_bytes) {
  if (s.size() <= max_bytes) return std::string(s);
  size_t end = max_bytes;
  while (end > 0 && (static_cast<uint8_t>(s[end]) & 0xc0) == 0x80) --end;  // back to the start of a character
  return std::string(s.substr(0, end));
}

std::string printable(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (size_t i = 0; i < s.size();) {
    const size_t n = sequence_length(s, i);
    const auto b0 = static_cast<uint8_t>(s[i]);
    if (n == 0) {
      append_hex(out, "\\x%02x", b0);
      ++i;
      continue;
    }
    if (n == 2 && b0 == 0xc2 && static_cast<uint8_t>(s[i + 1]) < 0xa0) {  // C1: U+0080 to U+009F
      append_hex(out, "\\u%04x", static_cast<uint8_t>(s[i + 1]));
    } else if (b0 == '\\') {
      out += "\\\\";
    } else if (b0 == '\n') {
      out += "\\n";
    } else if (b0 == '\r') {
      out += "\\r";
    } else if (b0 == '\t') {
      out += "\\t";
    } else if (b0 < 0x20 || b0 == 0x7f) {
      append_hex(out, "\\x%02x", b0);
    } else {
      out.append(s, i, n);
    }
    i += n;
  }
  return out;
}

}  // namespace kiln::proto
