// `kiln bake lightmap`: its flags, the imported scene (client/import) and an optional job file become a
// kiln.v1.JobSpec with a lightmap job, and the blobs it refers to, which the command uploads before it submits.
#pragma once

#include <iosfwd>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "client/cli/args.h"
#include "client/import/scene_import.h"
#include "proto/kiln.pb.h"

namespace kiln::cli {

struct LightmapBake {
  v1::JobSpec spec;         // the settings from the flags and the job file; the scene is merged in by merge_scene
  std::string scene_file;   // glTF, OBJ or FBX
  std::string env_file;     // --env IMAGE, uploaded; empty without
  std::string vdb_file;     // --vdb FILE, uploaded for the job file's vdb media without a file; empty without
  std::string job_file;     // --job FILE.textproto, empty without
  std::string job_text;     // its text
  v1::LightmapJob overlay;  // its contents
  int imported_lights = 0;  // lights before the job file's (set by merge_scene), to tell errors apart
  v1::ProbeVolume probe_flags;  // what the probe flags gave (probes_flags.h), before the job file's probes
};

// Every flag `kiln bake lightmap` accepts, the global ones included.
std::vector<FlagSpec> bake_lightmap_flag_specs();

// The flags and the job file; `flags.positional` starts with "lightmap" (or "probes": `kiln bake probes`, whose
// spec make_probes_job turns into a probes job once merged). Throws UsageError naming the flag (or the
// job file, "FILE:LINE:COLUMN: ...") for what is malformed, out of range, or missing.
LightmapBake lightmap_bake_from_flags(const Flags& flags);
LightmapBake lightmap_bake_from_flags(const std::vector<std::string>& args);

// Puts the imported scene (meshes, instances, materials, textures, lights) under the job file's overrides, lights
// and environment, and the flags' settings over both: flags > job file > the importer's scene. The job file may not
// give meshes, instances, materials or textures (those come from SCENE): UsageError naming it.
void merge_scene(LightmapBake& bake, const v1::LightmapJob& imported);

// The uploaded --vdb file's digest into every vdb medium that gives no file of its own.
void set_vdb_digest(LightmapBake& bake, const v1::Digest& digest);

// Where a field the server refused ("job.lightmap.resolution") was given, for people: a flag, the scene file, the
// environment image or the job file (with its line when it wrote the field).
std::string lightmap_field_origin(const LightmapBake& bake, const std::string& field_path);

// UsageError naming the scene or environment file that does not exist.
void require_lightmap_files(const LightmapBake& bake);

// The scene of `bake`, imported, with what the importer dropped and what it found said on `err`. A scene that
// cannot be imported is a Failure (kExitUsage) saying why.
client::ImportedScene import_lightmap_scene(std::ostream& err, const LightmapBake& bake);

extern const std::string kBakeLightmapHelp;

}  // namespace kiln::cli
