#include "client/cli/args.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>

#include "client/cli/format.h"
#include "proto/byte_size.h"

namespace kiln::cli {

std::optional<std::string> Flags::get(const std::string& name) const {
  auto it = values.find(name);
  if (it == values.end() || it->second.empty()) return std::nullopt;
  return it->second.back();
}

std::vector<std::string> Flags::all(const std::string& name) const {
  auto it = values.find(name);
  return it == values.end() ? std::vector<std::string>{} : it->second;
}

std::vector<FlagSpec> global_flag_specs() {
  return {{"--server"},  {"--token-file"},  {"--tls-ca"}, {"--tls-cert"},
          {"--tls-key"}, {"--help", false}, {"-h", false}};
}

Flags parse_flags(const std::vector<std::string>& args, const std::vector<FlagSpec>& specs,
                  const std::string& command) {
  Flags flags;
  const std::string see = " (see `" + command + " --help`)";
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    if (arg == "--") {
      flags.positional.insert(flags.positional.end(), args.begin() + static_cast<std::ptrdiff_t>(i) + 1, args.end());
      break;
    }
    // A lone "-" is a positional argument (standard input); negative numbers only appear as values.
    if (arg.size() < 2 || arg[0] != '-') {
      flags.positional.push_back(arg);
      continue;
    }
    std::string name = arg, value;
    bool inline_value = false;
    if (const auto eq = arg.find('='); eq != std::string::npos && arg.rfind("--", 0) == 0) {
      name = arg.substr(0, eq);
      value = arg.substr(eq + 1);
      inline_value = true;
    }
    const FlagSpec* spec = nullptr;
    for (const auto& s : specs) {
      if (s.name == name) spec = &s;
    }
    if (!spec) throw UsageError("unknown option " + name + " for `" + command + "`" + see);
    if (spec->takes_value && !inline_value) {
      // A following flag is not a value: `--out --wait` means the value was forgotten.
      if (i + 1 >= args.size() || args[i + 1].rfind("--", 0) == 0) throw UsageError(name + ": missing value" + see);
      value = args[++i];
    } else if (!spec->takes_value && inline_value) {
      throw UsageError(name + ": takes no value, got '" + value + "'" + see);
    }
    auto& slot = flags.values[name];
    if (!slot.empty() && !spec->repeatable) throw UsageError(name + ": given twice" + see);
    slot.push_back(value);
  }
  return flags;
}

double parse_number(const std::string& flag, const std::string& text) {
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || std::isspace(static_cast<unsigned char>(text[0]))) {
    throw UsageError(flag + ": expected a number, got '" + text + "'");
  }
  if (!std::isfinite(v)) throw UsageError(flag + ": must be a finite number, got '" + text + "'");
  return v;
}

double parse_number_in(const std::string& flag, const std::string& text, const bounds::Range& range) {
  const double v = parse_number(flag, text);
  if (range.contains(v)) return v;
  throw UsageError(flag + ": must be in " + (range.lo_open ? "(" : "[") + format_number(range.lo) + ", " +
                   format_number(range.hi) + "], got " + text);
}

std::int64_t parse_whole(const std::string& flag, const std::string& text, const bounds::WholeRange& range) {
  const double v = parse_number(flag, text);
  if (v != std::floor(v) || v < static_cast<double>(range.lo) || v > static_cast<double>(range.hi)) {
    throw UsageError(flag + ": must be a whole number in [" + std::to_string(range.lo) + ", " +
                     std::to_string(range.hi) + "], got " + text);
  }
  return static_cast<std::int64_t>(v);
}

std::uint64_t parse_byte_size(const std::string& flag, const std::string& text, const bounds::WholeRange& range) {
  const std::optional<std::uint64_t> v = proto::parse_byte_size(text);
  if (!v || *v < static_cast<std::uint64_t>(range.lo) || *v > static_cast<std::uint64_t>(range.hi)) {
    throw UsageError(flag + ": must be a size in bytes in [" + std::to_string(range.lo) + ", " +
                     std::to_string(range.hi) + "], whole or with K, M, G or T (x1024) as in 512M or 4G, got " + text);
  }
  return *v;
}

}  // namespace kiln::cli
