// Command-line parsing for `kiln`: flags with and without values, numbers checked and named in errors.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "proto/bounds.h"

namespace kiln::cli {

// The command line is wrong: printed as one line, exit status 2.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A failure with its exit status, the message already written for people (3: connection, server or local I/O).
class Failure : public std::runtime_error {
 public:
  Failure(int status, const std::string& message) : std::runtime_error(message), status_(status) {}
  int status() const { return status_; }

 private:
  int status_;
};

inline constexpr int kExitOk = 0;
inline constexpr int kExitJobFailed = 1;  // the job failed or was cancelled
inline constexpr int kExitUsage = 2;
inline constexpr int kExitServer = 3;  // no connection, the server refused, or local I/O failed

struct FlagSpec {
  std::string name;  // with the dashes: "--alpha"
  bool takes_value = true;
  bool repeatable = false;
};

// Flags given, by name, each with its values in the order given ("" for a flag without a value).
struct Flags {
  std::vector<std::string> positional;
  std::map<std::string, std::vector<std::string>> values;

  bool has(const std::string& name) const { return values.count(name) != 0; }
  std::optional<std::string> get(const std::string& name) const;
  std::vector<std::string> all(const std::string& name) const;
};

// Accepts "--flag VALUE", "--flag=VALUE" and "--" (the rest is positional). `command` names the command in errors
// ("kiln bake material"). Throws UsageError for an unknown flag, a missing value, or a flag given twice.
Flags parse_flags(const std::vector<std::string>& args, const std::vector<FlagSpec>& specs, const std::string& command);

// The flags every command takes: --server, --token-file, --tls-ca, --tls-cert, --tls-key, --help.
std::vector<FlagSpec> global_flag_specs();

// Numbers from the command line; errors name the flag and repeat what was given.
double parse_number(const std::string& flag, const std::string& text);
// A finite number in the range (proto/bounds.h declares the protocol's).
double parse_number_in(const std::string& flag, const std::string& text, const bounds::Range& range);
// A whole number in the range; "1e6" is accepted as 1000000.
std::int64_t parse_whole(const std::string& flag, const std::string& text, const bounds::WholeRange& range);
// A size in bytes in the range, whole or with K, M, G or T (x1024): "512M", "4G".
std::uint64_t parse_byte_size(const std::string& flag, const std::string& text, const bounds::WholeRange& range);

}  // namespace kiln::cli
