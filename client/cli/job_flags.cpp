#include "client/cli/job_flags.h"

#include <algorithm>
#include <sstream>

#include "proto/kiln.pb.h"
#include "proto/text.h"

namespace kiln::cli {
namespace {

constexpr std::size_t kMaxNameBytes = 256;  // JobSpec.name

}  // namespace

const char* const kWaitingBakeOptionsHelp = R"(options:
  --out DIR                    wait, then write the outputs and report.json into DIR (created if missing)
  --wait                       wait and print what the bake cost, without writing the outputs
                               (neither: print the job id and return; `kiln watch ID` follows it)
  --priority N                 higher runs first, [-100, 100]; default 0
  --idempotency-key KEY        resubmitting with the same key and spec returns the first job
  --server HOST:PORT | unix:PATH, --token-file FILE, --tls-ca FILE   see `kiln --help`
)";

std::vector<FlagSpec> bake_flag_specs(std::initializer_list<const char*> with_value,
                                      std::span<const char* const> job_flags,
                                      std::initializer_list<const char*> switches) {
  std::vector<FlagSpec> specs = global_flag_specs();
  for (const char* flag : with_value) specs.push_back({flag});
  for (const char* flag : job_flags) specs.push_back({flag});
  for (const char* flag : switches) specs.push_back({flag, false});
  specs.push_back({"--force", true, true});
  return specs;
}

std::string given_flag_words(const Flags& f, std::span<const char* const> flags) {
  std::string words;
  for (const char* flag : flags) {
    if (auto v = f.get(flag)) words += " " + std::string(flag + 2) + "=" + *v;
  }
  return words;
}

std::uint32_t whole_flag(const Flags& f, const char* flag, const bounds::WholeRange& range) {
  return static_cast<std::uint32_t>(parse_whole(flag, *f.get(flag), range));
}

void set_seed_and_drop_empty_quality(const Flags& f, v1::JobSpec& spec) {
  v1::Quality* q = spec.mutable_quality();
  if (auto v = f.get("--seed")) {
    q->set_seed(static_cast<std::uint64_t>(parse_whole("--seed", *v, bounds::kSeed)));
  }
  if (!q->has_samples() && !q->has_target_error() && !q->has_time_limit_seconds() && q->seed() == 0) {
    spec.clear_quality();
  }
}

void add_forced_effects(const Flags& f, v1::JobSpec& spec) {
  for (const std::string& force : f.all("--force")) {
    const auto eq = force.find('=');
    const std::string effect = force.substr(0, eq), value = eq == std::string::npos ? "" : force.substr(eq + 1);
    if (effect.empty() || (value != "on" && value != "off")) {
      throw UsageError("--force: expected EFFECT=on or EFFECT=off, got '" + force + "'");
    }
    if (effect.size() > 64) throw UsageError("--force: effect names are at most 64 bytes, got '" + effect + "'");
    if (spec.force_effects().count(effect)) throw UsageError("--force: effect '" + effect + "' given twice");
    (*spec.mutable_force_effects())[effect] = value == "on";
  }
  if (spec.force_effects_size() > 64) throw UsageError("--force: at most 64 effects");
}

void set_name(const Flags& f, v1::JobSpec& spec, const std::string& fallback) {
  if (auto v = f.get("--name")) {
    if (v->size() > kMaxNameBytes) {
      throw UsageError("--name: at most " + std::to_string(kMaxNameBytes) + " bytes, got " + std::to_string(v->size()));
    }
    spec.set_name(proto::to_utf8(*v));  // a protobuf string must be UTF-8; bytes of another encoding become U+FFFD
  } else {
    // The fallback names files, whose names need not be UTF-8, and is cut without cutting a character.
    const std::string name = proto::to_utf8(fallback);
    spec.set_name(name.size() > kMaxNameBytes ? proto::utf8_prefix(name, kMaxNameBytes - 3) + "..." : name);
  }
}

void parse_color(const std::string& flag, const std::string& text, const bounds::Range& range, v1::Color* c) {
  std::vector<std::string> parts;
  std::stringstream ss(text);
  for (std::string item; std::getline(ss, item, ',');) parts.push_back(item);
  if (!text.empty() && text.back() == ',') parts.push_back("");
  if (parts.size() != 1 && parts.size() != 3) {
    throw UsageError(flag + ": expected one value or three (R,G,B), got '" + text + "'");
  }
  double v[3];
  for (std::size_t i = 0; i < 3; ++i) v[i] = parse_number_in(flag, parts[parts.size() == 1 ? 0 : i], range);
  c->set_r(v[0]);
  c->set_g(v[1]);
  c->set_b(v[2]);
}

std::string hyphenated(std::string s) {
  std::replace(s.begin(), s.end(), '_', '-');
  return s;
}

}  // namespace kiln::cli
