#include "client/cli/lightmap_flags.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <ostream>
#include <sstream>
#include <string_view>

#include "client/cli/job_file.h"
#include "client/cli/job_flags.h"
#include "client/cli/probes_flags.h"
#include "proto/text.h"

namespace kiln::cli {

const std::string kBakeLightmapHelp = std::string(R"(usage: kiln bake lightmap SCENE [options] --out DIR

Bakes the lightmaps of a scene on the server: imports SCENE (glTF 2.0, OBJ or FBX, through Assimp: meshes with their
lightmap UVs from TEXCOORD_1, else TEXCOORD_0; instances; metallic-roughness materials as GGX over Lambert; base-colour
textures; emissive materials as area lights; KHR_lights_punctual), uploads its meshes, textures and environment (a
blob the server already holds is not sent again), submits the job, waits with a progress display and writes every
output into DIR: NAME_irradiance.exr (irradiance E in W/m^2), NAME_validity.exr, NAME_error.exr, NAME_preview.png for
each lightmap NAME (a mesh's name, or an atlas page with --texel-density), on request NAME_irradiance_denoised.exr, NAME_radiance.exr, NAME_ao.exr,
NAME_sh.exr, report.json (plan, samples, rays, time, error estimate, error-versus-time curve) and, with
--texel-density, lightmaps.json. What the importer
dropped or approximated is printed. Ctrl-C cancels the job on the server (a second Ctrl-C leaves it running).

the environment (at most one; none: black):
  --env IMAGE                  an equirectangular (2:1) OpenEXR, Radiance HDR, PNG or JPEG file
  --env-constant C | R,G,B     a constant radiance in the working space (lin_rec709), each in [0, 1e6]
  --env-rotation DEG           turn the image about +Y (right-handed), [-360, 360]; default 0 (image only)
  --env-intensity X            multiply the environment's radiance, (0, 1e6]; default 1
the bake:
  --resolution N               texels on a side of every lightmap, [4, 8192]; default 256
  --target-error E             the error per texel the adaptive sampling aims at, (0, 1]; default 0.01
  --error-metric M             what the error is relative to: lightmap (default: the lightmap's brightness, what an
                               RMSE over the map measures; dark texels take fewer samples) or texel (each texel's own
                               value: the same relative precision everywhere)
  --max-samples N              most samples per texel, [1, 1048576]; default 4096
  --time-limit S               stop after S seconds (the current pass completes), (0, 604800]; default none
  --seed N                     random seed; the same scene, settings and seed give the same bytes
  --padding N                  texels of dilation around charts, [0, 64]; default 4 (with --texel-density also
                               the texels between two instances' charts, at least 2)
atlas pages (none of these: one lightmap per mesh at --resolution):
  --texel-density D            pack every instance's chart into square atlas pages at D texels per metre of surface,
                               (0, 1e6]; outputs are per page (page0_irradiance.exr, ...) with lightmaps.json: each
                               instance's page and the scale and offset of its lightmap UVs in it
  --page-size N                texels on a side of a page, [16, 8192]; default 1024
  --max-pages N                most pages, [1, 4096]; default 4 (fewer for pages above 2048^2); charts that do not fit
                               are all scaled down to fit, and the report says by how much
  --uniform-pages              every page --page-size on a side (for a texture array); default: each page the
                               smallest square (a multiple of 4 texels) that holds its charts
  --memory-limit BYTES         the most memory the bake may hold, [64M, 1P], e.g. 4G (K, M, G, T: x1024); default
                               and upper bound: the server's --memory-limit. A bake larger than that samples its
                               lightmaps a tile at a time (the same images within the noise; report.json's memory)
lightmap UVs:
  --generate-uvs M             auto (default): kilnd generates lightmap UVs for meshes without usable ones (none,
                               outside [0, 1], or overlapping: mirrored or shared texture UVs); always: for every
                               mesh; never: a mesh without usable UVs gets no lightmap. Each mesh that got them is
                               written as MESH_uv.bin (kiln mesh layout) and listed in report.json's generated_uvs
  --max-bounces N              cap on the bounces the planner chooses, [0, 1024]; default 64
  --radiance                   also write NAME_radiance.exr (rho E / pi)
  --ao                         also write NAME_ao.exr (ambient occlusion)
  --directional                also write NAME_sh.exr (order-1 SH of incoming radiance)
  --denoise                    also write NAME_irradiance_denoised.exr: the irradiance through an edge-aware filter
                               guided by normals, positions, charts and each texel's estimated error (biased; the raw
                               NAME_irradiance.exr is written as always)
  --no-preview                 do not render NAME_preview.png
  --no-stitch-seams            write the texels along seams as baked: do not adjust them so that bilinear lookups on
                               both sides of an edge that lies on two chart borders agree (stitching is on by default)
light probes (docs/PROBES.md), baked in the same job: probes.vdb, probes_preview.png:
  --probes S                   bake light probes S scene units apart, (0, 1e6], within --max-distance of geometry
  --max-distance D             probes only within D of a triangle, [0, 1e6]; default 2 x spacing
  --max-probes N               [1, 4194304]; default 262144 (more double the spacing; the report says so)
  --region LX,LY,LZ,HX,HY,HZ   a box to fill with probes (repeatable, at most 16); default: the scene's bounds grown
                               by --max-distance
participating media (docs/MEDIA.md):
  --fog SA,SS[,G]              fog filling the scene: absorption and scattering coefficients per metre (grey), each
                               in [0, 1e6], and the Henyey-Greenstein asymmetry G in [-1, 1] (default 0); coloured
                               coefficients, boxes and VDB media go in the job file's media
  --vdb FILE.vdb               an OpenVDB file, uploaded, for the job file's vdb media that give no file digest
  --job FILE.textproto         a kiln.v1.LightmapJob in protobuf text format merged over the imported scene: its
                               material_overrides (any material by name, with any model of the BRDF library), lights
                               (point, spot, directional sun, rect, disk), media and environment are added, its settings
                               used where no flag is given; meshes, instances, materials and textures come from SCENE
  --force EFFECT=on|off        make the planner simulate or skip an effect, by the name its plan reports (repeatable)
  --name TEXT                  a name for people in `kiln jobs` (default: the scene file and its flags)
)") + kWaitingBakeOptionsHelp + R"(
example:
  /usr/bin/python3 client/examples/scenes/cornell_box.py out/cornell_box.gltf
  kiln bake lightmap out/cornell_box.gltf --resolution 64 --target-error 0.05 --out out/cornell_box
  kiln bake lightmap out/cornell_box.gltf --texel-density 32 --page-size 256 --target-error 0.05 --out out/pages
)";

namespace {

const char* const kJobFlags[] = {
    "--env-constant", "--env-rotation", "--env-intensity", "--resolution",   "--target-error", "--max-samples",
    "--time-limit",   "--seed",         "--padding",       "--max-bounces",  "--error-metric", "--texel-density",
    "--page-size",    "--max-pages",    "--memory-limit",  "--generate-uvs", "--fog"};

std::string default_name(const Flags& f, const std::string& scene) {
  std::string name = f.positional[0] + " " + std::filesystem::path(scene).filename().string();
  if (auto v = f.get("--env")) name += " env=" + std::filesystem::path(*v).filename().string();
  name += given_flag_words(f, kJobFlags);
  for (const char* flag :
       {"--radiance", "--ao", "--directional", "--denoise", "--no-preview", "--no-stitch-seams", "--uniform-pages"}) {
    if (f.has(flag)) name += " " + std::string(flag + 2);
  }
  if (auto v = f.get("--job")) name += " job=" + std::filesystem::path(*v).filename().string();
  if (auto v = f.get("--vdb")) name += " vdb=" + std::filesystem::path(*v).filename().string();
  for (const char* flag : {"--spacing", "--probes", "--max-distance", "--max-probes", "--region"}) {
    for (const std::string& v : f.all(flag)) name += " " + std::string(flag + 2) + "=" + v;
  }
  return name;
}

// The job file is a LightmapJob in text format, parsed as the `lightmap` of a JobSpec so that errors carry its lines:
// the wrapper sits on the first line, and only that line's columns shift.
constexpr std::string_view kOverlayWrapper = "lightmap { ";

std::string wrapped_overlay(const std::string& job_text) { return std::string(kOverlayWrapper) + job_text + "\n}"; }

// A column of the wrapped text's first line, in the job file.
int unwrapped_column(int column) { return std::max(column - static_cast<int>(kOverlayWrapper.size()), 1); }

// Reads and checks the job file.
void read_overlay(LightmapBake& bake) {
  std::ifstream in(bake.job_file, std::ios::binary);
  if (!in) throw UsageError("--job: cannot read " + bake.job_file);
  std::ostringstream s;
  s << in.rdbuf();
  bake.job_text = s.str();
  v1::JobSpec wrapped;
  try {
    parse_job_text(wrapped_overlay(bake.job_text), bake.job_file, wrapped);
  } catch (const UsageError& e) {
    // "FILE:1:COLUMN: ..." counts the wrapper's columns on the first line: take them off.
    const std::string text = e.what(), head = bake.job_file + ":1:";
    if (text.rfind(head, 0) != 0) throw;
    const std::size_t end = text.find(':', head.size());
    const int column = unwrapped_column(std::stoi(text.substr(head.size(), end - head.size())));
    throw UsageError(head + std::to_string(column) + text.substr(end));
  }
  bake.overlay = wrapped.lightmap();
  const v1::LightmapJob& o = bake.overlay;
  for (const auto& [count, what] :
       {std::pair{o.meshes_size(), "meshes"}, std::pair{o.instances_size(), "instances"},
        std::pair{o.materials_size(), "materials"}, std::pair{o.textures_size(), "textures"}}) {
    if (count > 0) {
      throw UsageError(bake.job_file + ": gives " + what +
                       "; they come from the scene file (use material_overrides "
                       "to change a material, lights to add lights)");
    }
  }
}

// The environment: an image (uploaded later) or a constant, turned and scaled.
void set_environment(const Flags& f, LightmapBake& bake) {
  v1::LightmapJob* job = bake.spec.mutable_lightmap();
  if (f.has("--env") && f.has("--env-constant")) {
    throw UsageError("--env-constant: give one environment: --env IMAGE or --env-constant R,G,B");
  }
  if (f.has("--env-rotation") && !f.has("--env")) {
    throw UsageError("--env-rotation: turns an --env image; a constant environment has no direction");
  }
  v1::SceneEnvironment* env = nullptr;
  if (auto v = f.get("--env")) {
    bake.env_file = *v;
    env = job->mutable_environment();
    env->mutable_image();  // its digest once uploaded
  }
  if (auto v = f.get("--env-constant")) {
    env = job->mutable_environment();
    parse_color("--env-constant", *v, bounds::kEnvironmentConstant, env->mutable_constant());
  }
  if (auto v = f.get("--env-rotation"))
    env->set_rotation_degrees(parse_number_in("--env-rotation", *v, bounds::kRotationDegrees));
  if (auto v = f.get("--env-intensity")) {
    if (!env) throw UsageError("--env-intensity: multiplies an environment: add --env IMAGE or --env-constant");
    env->set_intensity(parse_number_in("--env-intensity", *v, bounds::kEnvironmentIntensity));
  }
}

// --fog SA,SS[,G]: a grey medium filling the scene.
void add_fog(const Flags& f, LightmapBake& bake) {
  const auto v = f.get("--fog");
  if (!v) return;
  std::vector<std::string> parts;
  std::stringstream ss(*v);
  for (std::string item; std::getline(ss, item, ',');) parts.push_back(item);
  if (!v->empty() && v->back() == ',') parts.push_back("");
  if (parts.size() != 2 && parts.size() != 3) {
    throw UsageError("--fog: expected SIGMA_A,SIGMA_S or SIGMA_A,SIGMA_S,G (per metre; G the phase asymmetry), got '" +
                     *v + "'");
  }
  v1::Medium* fog = bake.spec.mutable_lightmap()->add_media();
  fog->set_name("fog");
  fog->set_fog(true);
  parse_color("--fog", parts[0], bounds::kMediumCoefficient, fog->mutable_sigma_a());
  parse_color("--fog", parts[1], bounds::kMediumCoefficient, fog->mutable_sigma_s());
  if (parts.size() == 3) fog->set_g(parse_number_in("--fog", parts[2], bounds::kMediumAsymmetry));
}

// --vdb FILE: the job file must have a vdb medium that waits for it, and no flag medium can use it.
void check_vdb_file(const Flags& f, LightmapBake& bake) {
  const auto v = f.get("--vdb");
  if (!v) return;
  bake.vdb_file = *v;
  for (const v1::Medium& m : bake.overlay.media()) {
    if (m.has_vdb() && !m.vdb().has_file()) return;
  }
  throw UsageError(
      "--vdb: no medium uses it: add to the job file a medium with `vdb { density_grid: \"density\" }` "
      "and no file, which --vdb's file then fills");
}

}  // namespace

void set_vdb_digest(LightmapBake& bake, const v1::Digest& digest) {
  for (v1::Medium& m : *bake.spec.mutable_lightmap()->mutable_media()) {
    if (m.has_vdb() && !m.vdb().has_file()) *m.mutable_vdb()->mutable_file() = digest;
  }
}

std::vector<FlagSpec> bake_lightmap_flag_specs() {
  std::vector<FlagSpec> specs =
      bake_flag_specs({"--name", "--out", "--priority", "--idempotency-key", "--env", "--job", "--vdb"}, kJobFlags,
                      {"--radiance", "--ao", "--directional", "--denoise", "--no-preview", "--no-stitch-seams",
                       "--uniform-pages", "--wait"});
  for (FlagSpec& s : lightmap_probe_flag_specs()) specs.push_back(std::move(s));
  return specs;
}

LightmapBake lightmap_bake_from_flags(const std::vector<std::string>& args) {
  return lightmap_bake_from_flags(parse_flags(args, bake_lightmap_flag_specs(), "kiln bake lightmap"));
}

LightmapBake lightmap_bake_from_flags(const Flags& f) {
  LightmapBake bake;
  const std::vector<std::string> words(f.positional.begin() + (f.positional.empty() ? 0 : 1), f.positional.end());
  if (words.empty()) {
    throw UsageError("missing scene: `kiln bake lightmap SCENE.gltf --out DIR` (see `kiln bake lightmap --help`)");
  }
  if (words.size() > 1) {
    throw UsageError("unexpected argument '" + words[1] + "': one scene file (see `kiln bake lightmap --help`)");
  }
  bake.scene_file = words[0];
  if (auto v = f.get("--job")) {
    bake.job_file = *v;
    read_overlay(bake);
  }
  v1::LightmapJob* job = bake.spec.mutable_lightmap();

  set_environment(f, bake);
  add_fog(f, bake);
  check_vdb_file(f, bake);
  if (f.has("--resolution")) job->set_resolution(whole_flag(f, "--resolution", bounds::kLightmapResolution));
  if (f.has("--padding")) job->set_padding(whole_flag(f, "--padding", bounds::kLightmapPadding));
  if (f.has("--max-bounces")) job->set_max_bounces(whole_flag(f, "--max-bounces", bounds::kMaxBounces));
  if (auto v = f.get("--texel-density"))
    job->set_texel_density(parse_number_in("--texel-density", *v, bounds::kTexelDensity));
  if (f.has("--page-size")) job->set_page_size(whole_flag(f, "--page-size", bounds::kAtlasPageSize));
  if (f.has("--max-pages")) job->set_max_pages(whole_flag(f, "--max-pages", bounds::kAtlasMaxPages));
  if (f.has("--uniform-pages")) job->set_uniform_pages(true);
  for (const char* flag : {"--page-size", "--max-pages", "--uniform-pages"}) {
    if (f.has(flag) && !job->has_texel_density() && !bake.overlay.has_texel_density()) {
      throw UsageError(std::string(flag) + ": sizes atlas pages; add --texel-density D to pack them");
    }
  }
  if (auto v = f.get("--memory-limit"))
    job->set_memory_limit_bytes(parse_byte_size("--memory-limit", *v, bounds::kLightmapMemoryLimit));
  if (f.has("--radiance")) job->set_radiance(true);
  if (f.has("--ao")) job->set_ao(true);
  if (f.has("--directional")) job->set_directional(true);
  if (f.has("--denoise")) job->set_denoise(true);
  if (auto v = f.get("--error-metric")) {
    if (*v == "lightmap") {
      job->set_error_metric(v1::LIGHTMAP_ERROR_METRIC_LIGHTMAP);
    } else if (*v == "texel") {
      job->set_error_metric(v1::LIGHTMAP_ERROR_METRIC_TEXEL);
    } else {
      throw UsageError("--error-metric: '" + *v + "' is not a metric: lightmap or texel");
    }
  }
  if (auto v = f.get("--generate-uvs")) {
    if (*v == "auto") {
      job->set_generate_uvs(v1::GENERATE_UVS_AUTO);
    } else if (*v == "always") {
      job->set_generate_uvs(v1::GENERATE_UVS_ALWAYS);
    } else if (*v == "never") {
      job->set_generate_uvs(v1::GENERATE_UVS_NEVER);
    } else {
      throw UsageError("--generate-uvs: '" + *v + "' is not a mode: auto, always or never");
    }
  }
  const bool probes_job = f.positional[0] == "probes";
  if (f.has("--no-preview") && !probes_job) job->set_preview(false);
  if (f.has("--no-stitch-seams")) job->set_stitch_seams(false);
  set_probe_flags(f, probes_job, bake.overlay.has_probes(), bake.probe_flags);
  if (bake.probe_flags.ByteSizeLong() > 0) *job->mutable_probes() = bake.probe_flags;

  v1::Quality* q = bake.spec.mutable_quality();
  if (auto v = f.get("--max-samples")) {
    q->set_samples(static_cast<std::uint64_t>(parse_whole("--max-samples", *v, bounds::kLightmapSamples)));
  }
  if (auto v = f.get("--target-error"))
    q->set_target_error(parse_number_in("--target-error", *v, bounds::kLightmapTargetError));
  if (auto v = f.get("--time-limit"))
    q->set_time_limit_seconds(parse_number_in("--time-limit", *v, bounds::kLightmapTimeLimitSeconds));
  set_seed_and_drop_empty_quality(f, bake.spec);
  add_forced_effects(f, bake.spec);
  set_name(f, bake.spec, default_name(f, bake.scene_file));
  return bake;
}

void merge_scene(LightmapBake& bake, const v1::LightmapJob& imported) {
  v1::LightmapJob merged = imported;
  bake.imported_lights = imported.lights_size();
  // The job file: overrides and lights added, environment and settings over the scene's.
  merged.MergeFrom(bake.overlay);
  // The flags: their settings over the job file's (an environment from the flags replaces the job file's whole).
  const v1::LightmapJob& flags = bake.spec.lightmap();
  if (flags.has_environment()) *merged.mutable_environment() = flags.environment();
  for (const v1::Medium& m : flags.media()) *merged.add_media() = m;  // --fog, after the job file's
  if (flags.has_resolution()) merged.set_resolution(flags.resolution());
  if (flags.has_padding()) merged.set_padding(flags.padding());
  if (flags.has_max_bounces()) merged.set_max_bounces(flags.max_bounces());
  if (flags.has_texel_density()) merged.set_texel_density(flags.texel_density());
  if (flags.has_page_size()) merged.set_page_size(flags.page_size());
  if (flags.has_max_pages()) merged.set_max_pages(flags.max_pages());
  if (flags.has_uniform_pages()) merged.set_uniform_pages(flags.uniform_pages());
  if (flags.has_memory_limit_bytes()) merged.set_memory_limit_bytes(flags.memory_limit_bytes());
  if (flags.radiance()) merged.set_radiance(true);
  if (flags.ao()) merged.set_ao(true);
  if (flags.directional()) merged.set_directional(true);
  if (flags.denoise()) merged.set_denoise(true);
  if (flags.error_metric() != v1::LIGHTMAP_ERROR_METRIC_DEFAULT) merged.set_error_metric(flags.error_metric());
  if (flags.generate_uvs() != v1::GENERATE_UVS_DEFAULT) merged.set_generate_uvs(flags.generate_uvs());
  if (flags.has_preview()) merged.set_preview(flags.preview());
  if (flags.has_stitch_seams()) merged.set_stitch_seams(flags.stitch_seams());
  if (flags.has_probes()) merge_probe_flags(flags.probes(), *merged.mutable_probes());
  *bake.spec.mutable_lightmap() = std::move(merged);
}

std::string lightmap_field_origin(const LightmapBake& bake, const std::string& field) {
  const std::string prefix = "job.lightmap.";
  auto starts = [&](const std::string& p) { return field.rfind(prefix + p, 0) == 0; };
  if (starts("environment.image") && !bake.env_file.empty()) return bake.env_file;
  if (starts("media[")) {
    // --fog's medium comes after the job file's.
    const int i = std::stoi(field.substr(prefix.size() + 6));
    if (i >= bake.overlay.media_size()) return "--fog";
    if (field.find(".vdb.file") != std::string::npos && !bake.overlay.media(i).vdb().has_file()) return bake.vdb_file;
  }
  static const std::pair<const char*, const char*> kFlags[] = {
      {"resolution", "--resolution"},
      {"padding", "--padding"},
      {"max_bounces", "--max-bounces"},
      {"texel_density", "--texel-density"},
      {"page_size", "--page-size"},
      {"max_pages", "--max-pages"},
      {"uniform_pages", "--uniform-pages"},
      {"memory_limit_bytes", "--memory-limit"},
      {"radiance", "--radiance"},
      {"ao", "--ao"},
      {"directional", "--directional"},
      {"denoise", "--denoise"},
      {"error_metric", "--error-metric"},
      {"generate_uvs", "--generate-uvs"},
      {"preview", "--no-preview"},
      {"stitch_seams", "--no-stitch-seams"},
      {"probes.spacing", "--probes"},
      {"environment.constant", "--env-constant"},
      {"environment.rotation_degrees", "--env-rotation"},
      {"environment.intensity", "--env-intensity"},
  };
  for (const auto& [name, flag] : kFlags) {
    if (field == prefix + name || starts(std::string(name) + ".")) return flag;
  }
  if (field.rfind("job.quality.samples", 0) == 0) return "--max-samples";
  if (field.rfind("job.quality.target_error", 0) == 0) return "--target-error";
  if (field.rfind("job.quality.time_limit_seconds", 0) == 0) return "--time-limit";
  if (field.rfind("job.force_effects", 0) == 0) return "--force";
  if (starts("meshes") || starts("instances") || starts("materials") || starts("textures")) return bake.scene_file;
  if (starts("lights[")) {
    const int i = std::stoi(field.substr(prefix.size() + 7));
    if (i < bake.imported_lights || bake.job_file.empty()) return bake.scene_file;
  }
  if (!bake.job_file.empty()) {
    // The job file's fields, located in its text.
    if (auto at = locate_field(wrapped_overlay(bake.job_text), field)) {
      if (at->rfind("1:", 0) == 0) *at = "1:" + std::to_string(unwrapped_column(std::stoi(at->substr(2))));
      return bake.job_file + ":" + *at;
    }
    return bake.job_file;
  }
  return bake.scene_file;
}

void require_lightmap_files(const LightmapBake& bake) {
  for (const std::string& file : {bake.scene_file, bake.env_file, bake.vdb_file}) {
    std::error_code ec;
    if (!file.empty() && !std::filesystem::is_regular_file(file, ec)) {
      throw UsageError(file + ": no such file (" +
                       (file == bake.scene_file ? "the scene to bake: glTF, OBJ or FBX"
                        : file == bake.env_file ? "the environment: an equirectangular EXR, HDR, PNG or JPEG"
                                                : "--vdb: an OpenVDB file") +
                       ")");
    }
  }
}

client::ImportedScene import_lightmap_scene(std::ostream& err, const LightmapBake& bake) {
  client::ImportedScene scene;
  try {
    scene = client::import_scene(bake.scene_file);
  } catch (const std::exception& e) {
    throw Failure(kExitUsage, e.what());
  }
  // Warnings quote names from the file as they are: escaped, they show bytes of other encodings and cannot drive
  // the terminal.
  for (const std::string& w : scene.warnings) {
    err << "kiln: " << bake.scene_file << ": " << proto::printable(w) << "\n";
  }
  err << "kiln: " << bake.scene_file << ": " << scene.job.meshes_size() << " meshes, " << scene.job.instances_size()
      << " instances, " << scene.job.materials_size() << " materials, " << scene.job.textures_size() << " textures, "
      << scene.job.lights_size() << " lights\n";
  return scene;
}

}  // namespace kiln::cli
