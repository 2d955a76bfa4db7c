#include "client/cli/build_manifest.h"

#include <google/protobuf/text_format.h>

#include <cctype>
#include <cmath>
#include <map>
#include <system_error>

#include "client/cli/args.h"
#include "client/cli/format.h"
#include "client/cli/job_file.h"
#include "proto/kiln_build.pb.h"

namespace kiln::cli {
namespace {

namespace fs = std::filesystem;
namespace pb = google::protobuf;

// A manifest holds settings; even ten thousand bakes fit well within this.
constexpr std::size_t kMaxManifestBytes = std::size_t{16} << 20;
constexpr int kMaxBakes = 10000;
constexpr std::size_t kMaxNameBytes = 128;

bool is_name_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.'; }

// "MANIFEST:LINE:COLUMN" of bake[i]'s field `field` (or of the entry), 1-based.
std::string origin_of(const std::string& label, const pb::TextFormat::ParseInfoTree& tree, int i,
                      const char* field = nullptr) {
  const pb::FieldDescriptor* bake = build::v1::Manifest::descriptor()->FindFieldByName("bake");
  auto location = tree.GetLocation(bake, i);
  if (field) {
    if (const auto* nested = tree.GetTreeForNested(bake, i)) {
      const pb::FieldDescriptor* f = build::v1::Bake::descriptor()->FindFieldByName(field);
      const auto at = nested->GetLocation(f, f->is_repeated() ? 0 : -1);
      if (at.line >= 0) location = at;
    }
  }
  return label + ":" + std::to_string(location.line + 1) + ":" + std::to_string(location.column + 1);
}

BakeChecks checks_of(const build::v1::Checks& c, const std::string& at) {
  BakeChecks checks;
  const auto positive = [&](const char* name, double v) {
    if (!(v > 0) || !std::isfinite(v)) {
      throw UsageError(at + ": checks." + name + ": must be a positive number, got " + format_number(v));
    }
    return v;
  };
  const auto fraction = [&](const char* name, double v) {
    if (!(v >= 0 && v <= 1)) throw UsageError(at + ": checks." + name + ": must be in [0, 1], got " + format_number(v));
    return v;
  };
  if (c.has_max_error()) checks.max_error = positive("max_error", c.max_error());
  if (c.has_max_seconds()) checks.max_seconds = positive("max_seconds", c.max_seconds());
  checks.energy_conserving = c.energy_conserving();
  if (c.has_max_reciprocity_error()) {
    checks.max_reciprocity_error = fraction("max_reciprocity_error", c.max_reciprocity_error());
  }
  if (c.has_max_invalid_texels()) checks.max_invalid_texels = fraction("max_invalid_texels", c.max_invalid_texels());
  return checks;
}

void check_name(const std::string& name, const std::string& at) {
  if (name.empty()) throw UsageError(at + ": a bake needs a name: add `name: \"...\"`");
  if (name.size() > kMaxNameBytes) {
    throw UsageError(at + ": name: at most " + std::to_string(kMaxNameBytes) + " bytes, got " +
                     std::to_string(name.size()));
  }
  for (char c : name) {
    if (!is_name_char(c)) {
      throw UsageError(at + ": name \"" + name + "\": use letters, digits, '_', '-' and '.' only");
    }
  }
}

}  // namespace

fs::path resolve_path(const fs::path& dir, const std::string& path) {
  const fs::path p(path);
  return (p.is_absolute() ? p : dir / p).lexically_normal();
}

std::vector<std::string> split_command(const std::string& command, const std::string& origin) {
  std::vector<std::string> words;
  std::string word;
  bool in_word = false;
  char quote = 0;
  for (char c : command) {
    if (quote) {
      if (c == quote) {
        quote = 0;
      } else {
        word += c;
      }
    } else if (c == '"' || c == '\'') {
      quote = c;
      in_word = true;
    } else if (std::isspace(static_cast<unsigned char>(c))) {
      if (in_word) words.push_back(word);
      word.clear();
      in_word = false;
    } else {
      word += c;
      in_word = true;
    }
  }
  if (quote) throw UsageError(origin + ": command: a " + std::string(1, quote) + " is not closed");
  if (in_word) words.push_back(word);
  return words;
}

Manifest read_manifest(const std::string& path) {
  Manifest m;
  std::error_code ec;
  m.file = fs::is_directory(path, ec) ? fs::path(path) / kManifestName : fs::path(path);
  const std::string label = m.file.string();
  if (!fs::exists(m.file, ec)) {
    throw UsageError("no build manifest at " + label + ": give `kiln build MANIFEST`, or run in the folder of a " +
                     kManifestName + " (client/examples/build/ has one)");
  }
  m.dir = fs::absolute(m.file, ec).parent_path();
  const std::string text = read_text_file(label, "build manifest", kMaxManifestBytes);
  build::v1::Manifest message;
  parse_text_message(text, label, message);  // errors with their line and column
  pb::TextFormat::Parser parser;
  pb::TextFormat::ParseInfoTree tree;
  parser.WriteLocationsTo(&tree);
  parser.ParseFromString(text, &message);
  if (message.bake_size() == 0) throw UsageError(label + ": no bakes; add `bake { name: ... output: ... }` entries");
  if (message.bake_size() > kMaxBakes) {
    throw UsageError(label + ": " + std::to_string(message.bake_size()) + " bakes, more than " +
                     std::to_string(kMaxBakes) + "; split the build into several manifests");
  }
  std::map<std::string, std::string> names, outputs;  // -> where first given
  for (int i = 0; i < message.bake_size(); ++i) {
    const build::v1::Bake& b = message.bake(i);
    ManifestBake bake;
    bake.origin = origin_of(label, tree, i);
    check_name(b.name(), bake.origin);
    bake.name = b.name();
    if (auto [it, fresh] = names.emplace(b.name(), bake.origin); !fresh) {
      throw UsageError(origin_of(label, tree, i, "name") + ": a second bake named \"" + b.name() +
                       "\" (the first is at " + it->second + "); names must be unique");
    }
    switch (b.job_case()) {
      case build::v1::Bake::kJobFile:
        bake.job_file = resolve_path(m.dir, b.job_file());
        break;
      case build::v1::Bake::kCommand:
        bake.command = split_command(b.command(), origin_of(label, tree, i, "command"));
        if (bake.command.empty()) throw UsageError(origin_of(label, tree, i, "command") + ": command: empty");
        break;
      default:
        throw UsageError(bake.origin + ": bake \"" + b.name() +
                         "\" says nothing to bake: give `job_file: \"FILE.textproto\"` or `command: \"material ...\"`");
    }
    if (!b.inputs().empty()) {
      if (bake.command.empty()) {
        throw UsageError(origin_of(label, tree, i, "inputs") + ": bake \"" + b.name() +
                         "\": inputs (a glob) go with a command (`command: \"env --size 128\"`), not a job file");
      }
      bake.inputs = resolve_path(m.dir, b.inputs());
    }
    if (b.output().empty()) {
      throw UsageError(bake.origin + ": bake \"" + b.name() + "\" needs an output folder: add `output: \"DIR\"`");
    }
    bake.output = resolve_path(m.dir, b.output());
    if (auto [it, fresh] = outputs.emplace(bake.output.string(), bake.origin); !fresh) {
      throw UsageError(origin_of(label, tree, i, "output") + ": bake \"" + b.name() + "\" writes into " +
                       bake.output.string() + " like the bake at " + it->second + "; give each its own folder");
    }
    const auto& range = bounds::kPriority;
    if (b.priority() < range.lo || b.priority() > range.hi) {
      throw UsageError(origin_of(label, tree, i, "priority") + ": priority: must be in [" + std::to_string(range.lo) +
                       ", " + std::to_string(range.hi) + "], got " + std::to_string(b.priority()));
    }
    bake.priority = b.priority();
    bake.checks = checks_of(b.checks(), origin_of(label, tree, i, "checks"));
    m.bakes.push_back(std::move(bake));
  }
  return m;
}

}  // namespace kiln::cli
