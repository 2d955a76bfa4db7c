#include "client/cli/probes_flags.h"

#include <sstream>

#include "client/cli/job_flags.h"

namespace kiln::cli {

const std::string kBakeProbesHelp = std::string(R"(usage: kiln bake probes SCENE --spacing S [options] --out DIR

Bakes light probes (an irradiance volume) of a scene on the server: imports and uploads SCENE as `kiln bake lightmap`
does, places probes S scene units apart (at the centres of the cells of a lattice over the regions) wherever they lie
within --max-distance of a triangle, and at each bakes the order-2 spherical harmonics of the incoming radiance with
the lightmaps' transport (lights, environment, media) to the target error. Probes inside closed geometry are marked
invalid. Writes into DIR: probes.vdb (OpenVDB: float grids sh<K>_<r|g|b> for K = 0..8, validity, error; one active
voxel per probe; metadata giving the SH basis, its normalisation, units, colour space and spacing), probes_preview.png
(one layer of probes as white spheres lit by them) and report.json (probe counts: placed, valid, invalid inside
geometry, skipped far from geometry; samples, time, errors, the plan's decisions and why).

the probes:
  --spacing S                  between neighbouring probes, scene units, (0, 1e6]; required (or the job file's
                               probes { spacing: S })
  --max-distance D             probes only within D of a triangle, [0, 1e6]; default 2 x spacing
  --max-probes N               [1, 4194304]; default 262144 (more double the spacing; the report says so)
  --region LX,LY,LZ,HX,HY,HZ   a box to fill with probes (repeatable, at most 16); default: the scene's bounds grown
                               by --max-distance
  --no-preview                 do not render probes_preview.png
the environment and the bake (as `kiln bake lightmap`):
  --env IMAGE, --env-constant C | R,G,B, --env-rotation DEG, --env-intensity X
  --target-error E             the error per probe (its DC term's luminance) the sampling aims at, (0, 1]; default
                               0.01, relative to the mean brightness of the probes (--error-metric lightmap) or to
                               each probe's own (texel)
  --error-metric M, --max-samples N (per probe), --time-limit S, --seed N, --max-bounces N, --memory-limit BYTES
  --fog SA,SS[,G], --vdb FILE.vdb, --job FILE.textproto (a LightmapJob: lights, media, environment, overrides, and
                               a probes { ... } block with these settings), --force EFFECT=on|off, --name TEXT
)") + kWaitingBakeOptionsHelp + R"(
example:
  /usr/bin/python3 client/examples/scenes/cornell_box.py out/cornell_box.gltf
  kiln bake probes out/cornell_box.gltf --spacing 0.25 --target-error 0.05 --out out/probes
)";

namespace {

const char* const kProbeFlags[] = {"--max-distance", "--max-probes"};

// --region LX,LY,LZ,HX,HY,HZ: six numbers, each within the coordinate bound (the server checks lo < hi, naming it).
void add_region(const std::string& text, v1::ProbeVolume& volume) {
  std::vector<double> v;
  std::stringstream ss(text);
  for (std::string item; std::getline(ss, item, ',');)
    v.push_back(parse_number_in("--region", item, bounds::kProbeCoordinate));
  if (v.size() != 6) {
    throw UsageError("--region: expected six numbers LX,LY,LZ,HX,HY,HZ (the box's lowest and highest corners), got '" +
                     text + "'");
  }
  v1::MediumBox* box = volume.add_regions();
  box->mutable_lo()->set_x(v[0]), box->mutable_lo()->set_y(v[1]), box->mutable_lo()->set_z(v[2]);
  box->mutable_hi()->set_x(v[3]), box->mutable_hi()->set_y(v[4]), box->mutable_hi()->set_z(v[5]);
}

}  // namespace

std::vector<FlagSpec> bake_probes_flag_specs() {
  std::vector<FlagSpec> specs =
      bake_flag_specs({"--name", "--out", "--priority", "--idempotency-key", "--env", "--job", "--vdb", "--spacing"},
                      std::span<const char* const>(kProbeFlags), {"--no-preview", "--wait"});
  for (const char* flag : {"--env-constant", "--env-rotation", "--env-intensity", "--target-error", "--max-samples",
                           "--time-limit", "--seed", "--max-bounces", "--error-metric", "--memory-limit", "--fog"}) {
    specs.push_back({flag});
  }
  specs.push_back({"--region", true, true});
  return specs;
}

std::vector<FlagSpec> lightmap_probe_flag_specs() {
  return {{"--probes"}, {"--max-distance"}, {"--max-probes"}, {"--region", true, true}};
}

void set_probe_flags(const Flags& f, bool probes_job, bool job_file_has_probes, v1::ProbeVolume& volume) {
  const char* spacing_flag = probes_job ? "--spacing" : "--probes";
  if (auto v = f.get(spacing_flag)) volume.set_spacing(parse_number_in(spacing_flag, *v, bounds::kProbeSpacing));
  if (!probes_job && !f.has("--probes") && !job_file_has_probes) {
    for (const char* flag : {"--max-distance", "--max-probes", "--region"}) {
      if (f.has(flag)) throw UsageError(std::string(flag) + ": places light probes; add --probes SPACING to bake them");
    }
  }
  if (auto v = f.get("--max-distance"))
    volume.set_max_distance(parse_number_in("--max-distance", *v, bounds::kProbeMaxDistance));
  if (f.has("--max-probes")) volume.set_max_probes(whole_flag(f, "--max-probes", bounds::kProbeCount));
  for (const std::string& r : f.all("--region")) add_region(r, volume);
  if (probes_job && f.has("--no-preview")) volume.set_preview(false);
}

void merge_probe_flags(const v1::ProbeVolume& flags, v1::ProbeVolume& merged) {
  if (flags.spacing() != 0) merged.set_spacing(flags.spacing());
  if (flags.has_max_distance()) merged.set_max_distance(flags.max_distance());
  if (flags.has_max_probes()) merged.set_max_probes(flags.max_probes());
  if (flags.has_preview()) merged.set_preview(flags.preview());
  if (flags.regions_size() > 0) *merged.mutable_regions() = flags.regions();  // the flags' boxes replace the file's
}

void make_probes_job(v1::JobSpec& spec) {
  v1::LightmapJob scene = spec.lightmap();
  if (scene.probes().spacing() == 0) {
    throw UsageError("--spacing: missing; probes need the distance between them: add --spacing S");
  }
  v1::ProbesJob* job = spec.mutable_probes();  // clears the lightmap job (one oneof)
  *job->mutable_volume() = scene.probes();
  scene.clear_probes();
  *job->mutable_scene() = std::move(scene);
}

std::string probes_field_origin(const LightmapBake& bake, const std::string& field) {
  const std::string volume = "job.probes.volume.", scene = "job.probes.scene";
  if (field.rfind(volume, 0) == 0) {
    const std::string rest = field.substr(volume.size());
    const v1::ProbeVolume& given = bake.probe_flags;
    if (rest.rfind("spacing", 0) == 0 && given.spacing() != 0) return "--spacing";
    if (rest.rfind("max_distance", 0) == 0 && given.has_max_distance()) return "--max-distance";
    if (rest.rfind("max_probes", 0) == 0 && given.has_max_probes()) return "--max-probes";
    if (rest.rfind("regions", 0) == 0 && given.regions_size() > 0) return "--region";
    // The job file's probes { ... } block, located as the lightmap job's field.
    return lightmap_field_origin(bake, "job.lightmap.probes." + rest);
  }
  if (field.rfind(scene, 0) == 0) return lightmap_field_origin(bake, "job.lightmap" + field.substr(scene.size()));
  return lightmap_field_origin(bake, field);
}

}  // namespace kiln::cli
