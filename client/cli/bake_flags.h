// `kiln bake material`: its flags become a kiln.v1.JobSpec. The flag names are those of kiln-brdf
// (bakers/tools/kiln_brdf.cpp), so a material tried out locally bakes on the server with the same words.
#pragma once

#include <string>
#include <vector>

#include "client/cli/args.h"

namespace kiln::v1 {
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
// "job.material.ggx.alpha" -> "--alpha", "job.material.schlick_double.bottom.c.g" -> "--bottom-c",
// "job.material.layered.specular.ggx.alpha" -> "--specular-alpha";
// "" when no flag sets it.
std::string flag_for_field(const std::string& field_path);

extern const char* const kBakeMaterialHelp;

}  // namespace kiln::cli
