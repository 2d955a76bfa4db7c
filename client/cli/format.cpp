#include "client/cli/format.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <ctime>

namespace kiln::cli {

std::string format_number(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

std::string format_duration(double s) {
  if (!(s >= 0) || !std::isfinite(s)) return "?";
  char buf[48];
  if (s < 10) {
    std::snprintf(buf, sizeof buf, "%.2f s", s);
  } else if (s < 60) {
    std::snprintf(buf, sizeof buf, "%.1f s", s);
  } else if (s < 3600) {
    const long t = std::lround(s);
    std::snprintf(buf, sizeof buf, "%ld min %02ld s", t / 60, t % 60);
  } else {
    const long t = std::lround(s / 60);
    std::snprintf(buf, sizeof buf, "%ld h %02ld min", t / 60, t % 60);
  }
  return buf;
}

namespace {

// `n` divided by `base` until below it, with three significant digits and the unit reached: "12.3 k", "4.19 MiB".
std::string scaled(std::uint64_t n, double base, const char* const (&units)[6]) {
  double v = static_cast<double>(n);
  int u = -1;
  while (v >= base && u < 5) {
    v /= base;
    ++u;
  }
  char buf[32];
  std::snprintf(buf, sizeof buf, v < 10 ? "%.2f %s" : v < 100 ? "%.1f %s" : "%.0f %s", v, units[u]);
  return buf;
}

}  // namespace

std::string format_count(std::uint64_t n) {
  if (n < 1000) return std::to_string(n);
  return scaled(n, 1000, {"k", "M", "G", "T", "P", "E"});
}

std::string format_bytes(std::uint64_t n) {
  if (n < 1024) return std::to_string(n) + " B";
  return scaled(n, 1024, {"KiB", "MiB", "GiB", "TiB", "PiB", "EiB"});
}

std::string format_error(double e) {
  if (!(e >= 0) || !std::isfinite(e)) return "unknown";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2g", e);
  if (e != 0 && (e < 1e-3 || e >= 1e3)) std::snprintf(buf, sizeof buf, "%.1e", e);
  return buf;
}

std::string json_string(std::string_view s) {
  std::string out = "\"";
  for (const char c : s) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
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

namespace {

std::string strftime_of(double unix_seconds, const char* pattern, bool utc) {
  const std::time_t t = static_cast<std::time_t>(unix_seconds);
  std::tm tm{};
  if (utc) {
    gmtime_r(&t, &tm);
  } else {
    localtime_r(&t, &tm);
  }
  char buf[32];
  std::strftime(buf, sizeof buf, pattern, &tm);
  return buf;
}

}  // namespace

std::string format_time(double unix_seconds) {
  if (!(unix_seconds > 0) || !std::isfinite(unix_seconds)) return "-";
  return strftime_of(unix_seconds, "%Y-%m-%d %H:%M:%S", false);
}

std::string format_iso_utc(double unix_seconds) { return strftime_of(unix_seconds, "%Y-%m-%dT%H:%M:%S", true); }

}  // namespace kiln::cli
