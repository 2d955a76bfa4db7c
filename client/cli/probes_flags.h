// Light probes from the command line: `kiln bake probes SCENE --spacing S --out DIR` (a ProbesJob whose scene is
// built exactly as `kiln bake lightmap` builds its LightmapJob: the same import, job file, environment, media and
// quality flags), and `--probes S` on `kiln bake lightmap` (probes baked in the same job). Both take --max-distance,
// --max-probes and --region (repeatable); a job file's `probes { ... }` block gives the same settings, under the flags.
#pragma once

#include <string>
#include <vector>

#include "client/cli/args.h"
#include "client/cli/lightmap_flags.h"
#include "proto/kiln.pb.h"

namespace kiln::cli {

extern const std::string kBakeProbesHelp;

// Every flag `kiln bake probes` accepts: the lightmap bake's scene, quality and media flags, --spacing and the
// probe flags; not the lightmap-only ones (--resolution, atlas pages, extra outputs).
std::vector<FlagSpec> bake_probes_flag_specs();
// The probe flags `kiln bake lightmap` adds to its own.
std::vector<FlagSpec> lightmap_probe_flag_specs();

// The probe flags into `volume` (spacing from --spacing for `kiln bake probes`, --probes for a lightmap bake).
// Throws UsageError naming the flag: out of range, a malformed --region, or a probe flag on a lightmap bake without
// --probes (unless the job file has probes).
void set_probe_flags(const Flags& f, bool probes_job, bool job_file_has_probes, v1::ProbeVolume& volume);
// The flags' probe settings over the job file's.
void merge_probe_flags(const v1::ProbeVolume& flags, v1::ProbeVolume& merged);

// The merged lightmap spec of `kiln bake probes` made a probes job: its `probes` become the job's volume. UsageError
// when no spacing was given.
void make_probes_job(v1::JobSpec& spec);

// Where a field of a probes job the server refused was given: a probe flag, or what lightmap_field_origin says of
// the same field in the lightmap job the command built.
std::string probes_field_origin(const LightmapBake& bake, const std::string& field);

}  // namespace kiln::cli
