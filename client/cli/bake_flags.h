// `kiln bake material`: its flags become a kiln.v1.JobSpec. The flag names are those of kiln-brdf
// (bakers/tools/kiln_brdf.cpp), so a material tried out locally bakes on the server with the same words.
#pragma once

#include <string>
#include <vector>

#include "client/cli/args.h"

namespace kiln::v1 {
class Color;
class JobSpec;
}

namespace kiln::cli {

// Every flag `kiln bake material` accepts: the material's, the submission's (--out, --priority,
// --idempotency-key) and the global ones.
std::vector<FlagSpec> bake_material_flag_specs();

// The job spec the flags ask for. Flags that do not describe the job (--out, --server, ...) are ignored here.
// Throws UsageError naming the flag: a missing --model, a malformed or out-of-range value, a parameter the model
// does not have (--sigma with --model ggx), or a combination that would be ignored (--f0 without --fresnel schlick).
v1::JobSpec material_spec_from_flags(const Flags& flags);
// The same from the words after `kiln bake material`.
v1::JobSpec material_spec_from_flags(const std::vector<std::string>& args);

// The flag that sets a field of the job spec, so that the server's errors can name what the user typed:
// "job.material.ggx.alpha" -> "--alpha", "job.material.schlick_double.bottom.c.g" -> "--bottom-c";
// "" when no flag sets it.
std::string flag_for_field(const std::string& field_path);

// Shared by the bake commands: --force EFFECT=on|off (repeatable) into spec.force_effects, and --name (else
// `default_name`, shortened to the protocol's 256 bytes). Throw UsageError naming the flag.
void add_forced_effects(const Flags& flags, v1::JobSpec& spec);
void set_name(const Flags& flags, v1::JobSpec& spec, const std::string& default_name);

// A colour flag: one value (grey) or three (R,G,B), each in [0, hi]. Throws UsageError naming the flag.
void parse_color(const std::string& flag, const std::string& text, double hi, v1::Color* c);

extern const char* const kBakeMaterialHelp;

}  // namespace kiln::cli
