// The planner of `kiln build`: each bake of the manifest (a job file, a `kiln bake` command, or a command over a
// glob's files) becomes a job spec with its inputs' digests computed locally, so that the runner can ask the server
// for every digest at once and upload only what it lacks.
#pragma once

#include <filesystem>
#include <functional>
#include <iosfwd>
#include <map>
#include <string>
#include <vector>

#include "client/cli/build_manifest.h"
#include "proto/kiln.pb.h"

namespace kiln::cli {

struct PlannedBake {
  std::string name;    // the manifest's, NAME/STEM for a glob's file
  std::string origin;  // "MANIFEST:LINE:COLUMN" of its entry
  std::string type;    // the JobSpec's job: "material", "environment", "lightmap" or "probes"
  v1::JobSpec spec;    // with its inputs' digests
  std::filesystem::path output;
  std::int32_t priority = 0;
  BakeChecks checks;
  // Where the user gave a field the server names (a job file's line, a flag, an input file), for its refusals.
  std::function<std::string(const std::string& field_path)> where;
};

struct BuildPlan {
  std::vector<PlannedBake> bakes;
  std::map<std::string, std::string> blobs;  // SHA-256 hex -> bytes: every input of every bake, once
};

// Plans the manifest's bakes, only those named in `only` if it is not empty (a glob's bakes by the glob's name or
// one by NAME/STEM). Scene imports say what they found on `err`. Throws UsageError naming the manifest's line for
// a command that does not parse, a missing input, a glob that matches nothing, a name in `only` that names no bake.
BuildPlan plan_build(const Manifest& manifest, const std::vector<std::string>& only, std::ostream& err);

}  // namespace kiln::cli
