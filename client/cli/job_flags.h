// What the `kiln bake` commands share in turning flags into a kiln.v1.JobSpec: the flag lists, colours, whole
// numbers, the seed, --force, --name and the default name.
#pragma once

#include <cstdint>
#include <initializer_list>
#include <span>
#include <string>
#include <vector>

#include "client/cli/args.h"

namespace kiln::v1 {
class Color;
class JobSpec;
}  // namespace kiln::v1

namespace kiln::cli {

// The options of the bake commands that may or may not wait for the job, as their --help lists them.
extern const char* const kWaitingBakeOptionsHelp;

// The flags of a bake command: the global ones, `with_value` and `job_flags` (each takes a value), `switches` (no
// value), and --force (repeatable).
std::vector<FlagSpec> bake_flag_specs(std::initializer_list<const char*> with_value,
                                      std::span<const char* const> job_flags,
                                      std::initializer_list<const char*> switches);

// " NAME=VALUE" for each of `flags` given, in their order, the dashes left out: the words of a default job name.
std::string given_flag_words(const Flags& f, std::span<const char* const> flags);

// A whole-number flag that was given, in [lo, hi]. Throws UsageError naming the flag.
std::uint32_t whole_flag(const Flags& f, const char* flag, const bounds::WholeRange& range);

// --seed into spec.quality, if given: whole numbers a double holds exactly (the flag is parsed as a number like the
// others). Then a quality with nothing set (seed 0 is the default) is left out of the spec.
void set_seed_and_drop_empty_quality(const Flags& f, v1::JobSpec& spec);

// --force EFFECT=on|off (repeatable) into spec.force_effects, and --name (else `default_name`, shortened to the
// protocol's 256 bytes). Throw UsageError naming the flag.
void add_forced_effects(const Flags& flags, v1::JobSpec& spec);
void set_name(const Flags& flags, v1::JobSpec& spec, const std::string& default_name);

// A colour flag: one value (grey) or three (R,G,B), each in [0, hi]. Throws UsageError naming the flag.
void parse_color(const std::string& flag, const std::string& text, const bounds::Range& range, v1::Color* c);

// Job files spell names with underscores (oren_nayar, cook_torrance), flags with hyphens: both are accepted.
std::string hyphenated(std::string s);

}  // namespace kiln::cli
