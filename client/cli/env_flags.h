// `kiln bake env`: its flags become a kiln.v1.JobSpec with an environment job, and the local files it reads (an
// equirectangular image, or six cube faces), which the command uploads as blobs before it submits.
#pragma once

#include <string>
#include <vector>

#include "client/cli/args.h"
#include "proto/kiln.pb.h"

namespace kiln::cli {

struct EnvironmentBake {
  v1::JobSpec spec;                // the image's or faces' digests left empty until set_input_digests
  std::vector<std::string> files;  // one image, or six faces (+X, -X, +Y, -Y, +Z, -Z); empty for --constant
};

// Every flag `kiln bake env` accepts, the global ones included.
std::vector<FlagSpec> bake_env_flag_specs();

// The job the flags ask for; `flags.positional` starts with "env". Throws UsageError naming the flag: no source or
// two, a malformed or out-of-range value, a setting a constant colour would ignore (--color-space with
// --constant).
EnvironmentBake environment_bake_from_flags(const Flags& flags);
// The same from the words after `kiln bake`.
EnvironmentBake environment_bake_from_flags(const std::vector<std::string>& args);

// Puts the uploaded files' digests (in the order of `files`) into the spec.
void set_input_digests(EnvironmentBake& bake, const std::vector<v1::Digest>& digests);

// UsageError naming the first of the bake's files that does not exist.
void require_environment_files(const EnvironmentBake& bake);

// Where a field the server refused was given, for people: the image or face file, else the flag.
std::string environment_field_origin(const EnvironmentBake& bake, const std::string& field);

extern const std::string kBakeEnvHelp;

}  // namespace kiln::cli
