#include "client/cli/env_flags.h"

#include <algorithm>
#include <filesystem>
#include <sstream>

#include "client/cli/bake_flags.h"
#include "client/cli/job_flags.h"

namespace kiln::cli {

const std::string kBakeEnvHelp = std::string(R"(usage: kiln bake env IMAGE [options]
       kiln bake env --constant R,G,B [options]
       kiln bake env --faces PX NX PY NY PZ NZ [options]

Bakes an HDR environment on the server for image-based lighting: uploads the image (or the six faces; a file the
server already holds is not sent again), submits the job, waits with a progress display and, with --out, writes
every output into DIR: specular.ktx2 (the prefiltered specular cube, every level), specular_L{k}_{px,nx,py,ny,pz,nz}
.exr (the same levels as EXR faces), irradiance_*.exr, sh.txt (order-2 SH irradiance), dfg.exr (the split-sum
table), report.json and preview.png. Ctrl-C cancels the job on the server (a second Ctrl-C leaves it running).
The flags become a kiln.v1.JobSpec with an `environment` job (see client/examples/ for the same as job files).

the environment (exactly one):
  IMAGE                        an equirectangular (2:1) OpenEXR, Radiance HDR, PNG or JPEG file
  --constant C | R,G,B         a constant radiance in the working space (lin_rec709), each in [0, 1e6]
  --faces PX NX PY NY PZ NZ    six square face files, in the order +X, -X, +Y, -Y, +Z, -Z
image settings (not with --constant):
  --color-space S              the image's colour space, a space or role of the server's OpenColorIO config;
                               default the format's (lin_rec709 for EXR and HDR, srgb_texture for PNG and JPEG)
  --rotation DEG               turn the environment about +Y (right-handed), [-360, 360]; default 0
  --intensity X                multiply the radiance, (0, 1e6]; default 1
the bake:
  --lobe ggx|beckmann|cook-torrance|schlick   the specular lobe of the prefiltered chain and the DFG table
  --size N                     specular cube face size, a power of two in [4, 2048]; default 128
  --levels N                   mip levels, [1, log2(size) - 1]; default every level down to 4x4
  --irradiance-size N          irradiance cube face size, [1, 256]; default 32
  --dfg-size N                 DFG table resolution, [2, 1024]; default 64
  --dfg-samples N              samples per DFG entry, [16, 1048576]; default 1024
  --dfg-masking separable|height-correlated   the DFG table's Smith masking (ggx, beckmann, schlick lobes);
                               default height-correlated; cook-torrance uses its own V-groove G
  --samples N                  prefilter samples per texel, [4, 65536]; default: chosen per level for --target-error
  --target-error E             relative error per level the sample counts aim at, [0.0001, 1]; default 0.01
  --seed N                     random seed; the same spec and seed give the same bytes
  --no-preview                 do not render preview.png
  --force EFFECT=on|off        make the planner simulate or skip an effect, by the name its plan reports
                               (repeatable)
  --name TEXT                  a name for people in `kiln jobs` (default: the source and its flags)
)") + kWaitingBakeOptionsHelp + R"(
example:
  kiln bake env out/sky.exr --size 128 --out out/sky_env
)";

namespace {

// The flags that describe the job, in the order the default name lists them.
const char* const kJobFlags[] = {"--constant",    "--color-space", "--rotation",        "--intensity", "--lobe",
                                 "--size",        "--levels",      "--irradiance-size", "--dfg-size",  "--dfg-samples",
                                 "--dfg-masking", "--samples",     "--target-error",    "--seed"};

v1::EnvironmentLobe lobe_of(const std::string& flag_text) {
  const std::string text = hyphenated(flag_text);
  const std::pair<const char*, v1::EnvironmentLobe> kLobes[] = {{"ggx", v1::ENVIRONMENT_LOBE_GGX},
                                                                {"beckmann", v1::ENVIRONMENT_LOBE_BECKMANN},
                                                                {"cook-torrance", v1::ENVIRONMENT_LOBE_COOK_TORRANCE},
                                                                {"schlick", v1::ENVIRONMENT_LOBE_SCHLICK}};
  for (const auto& [name, lobe] : kLobes) {
    if (text == name) return lobe;
  }
  throw UsageError("--lobe: expected one of ggx, beckmann, cook-torrance, schlick, got '" + text + "'");
}

v1::Masking dfg_masking_of(const std::string& flag_text) {
  const std::string text = hyphenated(flag_text);
  if (text == "separable") return v1::MASKING_SEPARABLE;
  if (text == "height-correlated") return v1::MASKING_HEIGHT_CORRELATED;
  throw UsageError("--dfg-masking: expected separable or height-correlated, got '" + text + "'");
}

std::string default_name(const Flags& f, const std::vector<std::string>& files) {
  std::string name = "environment";
  if (files.size() == 1) name += " " + std::filesystem::path(files[0]).filename().string();
  if (files.size() == 6) name += " faces " + std::filesystem::path(files[0]).filename().string() + "...";
  return name + given_flag_words(f, kJobFlags) + (f.has("--no-preview") ? " no-preview" : "");
}

// The environment: an image, six faces or a constant, exactly one.
void set_source(const Flags& f, EnvironmentBake& bake) {
  v1::EnvironmentJob* job = bake.spec.mutable_environment();
  const bool constant = f.has("--constant"), faces = f.has("--faces");
  if (constant && faces) throw UsageError("--constant: give one environment: an image, --constant or --faces");
  if (constant) {
    if (!bake.files.empty()) {
      throw UsageError("--constant: give one environment, not also the file '" + bake.files[0] + "'");
    }
    parse_color("--constant", *f.get("--constant"), bounds::kEnvironmentConstant, job->mutable_constant());
    for (const char* flag : {"--color-space", "--rotation", "--intensity"}) {
      if (f.has(flag)) {
        throw UsageError(std::string(flag) +
                         ": applies to an image or faces; --constant is already radiance in the "
                         "working space");
      }
    }
  } else if (faces) {
    if (bake.files.size() != 6) {
      throw UsageError("--faces: expected six files (+X, -X, +Y, -Y, +Z, -Z), got " +
                       std::to_string(bake.files.size()));
    }
    job->mutable_faces();
  } else if (bake.files.empty()) {
    throw UsageError(
        "missing environment: `kiln bake env IMAGE`, `--constant R,G,B` or `--faces PX NX PY NY PZ NZ`"
        " (see `kiln bake env --help`)");
  } else if (bake.files.size() > 1) {
    throw UsageError("unexpected argument '" + bake.files[1] +
                     "': one image (six faces go with --faces; see `kiln bake env --help`)");
  } else {
    job->mutable_image();
  }
}

// The image's colour space, rotation and intensity, and the sizes and lobe of the bake.
void set_image_and_bake_settings(const Flags& f, v1::EnvironmentJob& env) {
  if (auto v = f.get("--color-space")) {
    if (v->empty() || v->size() > 64) throw UsageError("--color-space: expected a name of 1 to 64 bytes");
    env.set_color_space(*v);
  }
  if (auto v = f.get("--rotation"))
    env.set_rotation_degrees(parse_number_in("--rotation", *v, bounds::kRotationDegrees));
  if (auto v = f.get("--intensity"))
    env.set_intensity(parse_number_in("--intensity", *v, bounds::kEnvironmentIntensity));
  if (auto v = f.get("--lobe")) env.set_lobe(lobe_of(*v));
  if (f.has("--size")) {
    const std::uint32_t n = whole_flag(f, "--size", bounds::kCubeSize);
    if ((n & (n - 1)) != 0) throw UsageError("--size: must be a power of two in [4, 2048], got " + *f.get("--size"));
    env.set_size(n);
  }
  if (f.has("--levels"))
    env.set_levels(whole_flag(f, "--levels", bounds::kLevels));  // the server checks it against --size
  if (f.has("--irradiance-size")) env.set_irradiance_size(whole_flag(f, "--irradiance-size", bounds::kIrradianceSize));
  if (f.has("--dfg-size")) env.set_dfg_size(whole_flag(f, "--dfg-size", bounds::kDfgSize));
  if (f.has("--dfg-samples")) env.set_dfg_samples(whole_flag(f, "--dfg-samples", bounds::kDfgSamples));
  if (auto v = f.get("--dfg-masking")) env.set_dfg_masking(dfg_masking_of(*v));
  if (f.has("--no-preview")) env.set_preview(false);
}

}  // namespace

std::vector<FlagSpec> bake_env_flag_specs() {
  return bake_flag_specs({"--name", "--out", "--priority", "--idempotency-key"}, kJobFlags,
                         {"--faces", "--no-preview", "--wait"});
}

EnvironmentBake environment_bake_from_flags(const std::vector<std::string>& args) {
  return environment_bake_from_flags(parse_flags(args, bake_env_flag_specs(), "kiln bake env"));
}

EnvironmentBake environment_bake_from_flags(const Flags& f) {
  EnvironmentBake bake;
  bake.files.assign(f.positional.begin() + (f.positional.empty() ? 0 : 1), f.positional.end());
  set_source(f, bake);
  set_image_and_bake_settings(f, *bake.spec.mutable_environment());
  v1::Quality* q = bake.spec.mutable_quality();
  if (auto v = f.get("--samples"))
    q->set_samples(static_cast<std::uint64_t>(parse_whole("--samples", *v, bounds::kEnvironmentSamples)));
  if (auto v = f.get("--target-error"))
    q->set_target_error(parse_number_in("--target-error", *v, bounds::kEnvironmentTargetError));
  set_seed_and_drop_empty_quality(f, bake.spec);
  add_forced_effects(f, bake.spec);
  set_name(f, bake.spec, default_name(f, bake.files));
  return bake;
}

void set_input_digests(EnvironmentBake& bake, const std::vector<v1::Digest>& digests) {
  v1::EnvironmentJob* job = bake.spec.mutable_environment();
  if (job->has_image() && digests.size() == 1) {
    *job->mutable_image() = digests[0];
  } else if (job->has_faces() && digests.size() == 6) {
    job->mutable_faces()->clear_digests();
    for (const v1::Digest& d : digests) *job->mutable_faces()->add_digests() = d;
  } else {
    throw std::logic_error("set_input_digests: " + std::to_string(digests.size()) + " digests for this job's source");
  }
}

void require_environment_files(const EnvironmentBake& bake) {
  for (const std::string& file : bake.files) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(file, ec)) {
      throw UsageError(file + ": no such file (the environment to bake: an equirectangular EXR, HDR, PNG or JPEG)");
    }
  }
}

std::string environment_field_origin(const EnvironmentBake& bake, const std::string& field) {
  // The server names the image's field; the user named a file.
  for (std::size_t i = 0; i < bake.files.size(); ++i) {
    const std::string face = "job.environment.faces.digests[" + std::to_string(i) + "]";
    if (field.rfind("job.environment.image", 0) == 0 || field.rfind(face, 0) == 0) return bake.files[i];
  }
  return flag_for_field(field);
}

}  // namespace kiln::cli
