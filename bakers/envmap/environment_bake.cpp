#include "bakers/envmap/environment_bake.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <stdexcept>
#include <utility>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>

#include "bakers/bake/number_format.h"
#include "bakers/bake/range_check.h"
#include "bakers/envmap/cubemap.h"
#include "bakers/envmap/dfg.h"
#include "bakers/envmap/dfg_cache.h"
#include "bakers/envmap/environment_effect.h"
#include "bakers/envmap/environment_report.h"
#include "bakers/envmap/irradiance.h"
#include "bakers/envmap/prefilter.h"
#include "bakers/envmap/preview.h"
#include "bakers/envmap/sh.h"
#include "bakers/envmap/sun.h"
#include "bakers/image/exr.h"
#include "bakers/image/ktx2.h"

namespace kiln::envmap {
namespace {

using bake::format_number;

bool is_power_of_two(int n) { return n > 0 && (n & (n - 1)) == 0; }

int default_levels(int size) {
  int levels = 1;
  while ((size >> levels) >= 4) ++levels;  // down to 4×4: smaller faces carry no useful directional detail
  return levels;
}

// Irradiance varies slowly: convolving a source larger than this only costs time (cost ∝ source² × output²).
constexpr int kIrradianceSourceSize = 32;

image::FloatImage face_image(const Cubemap& cube, int face, const std::string& what) {
  image::FloatImage img;
  img.width = img.height = cube.size();
  img.channels = 3;
  img.channel_names = {"R", "G", "B"};
  img.pixels.reserve(static_cast<size_t>(img.width) * img.height * 3);
  for (int y = 0; y < cube.size(); ++y) {
    for (int x = 0; x < cube.size(); ++x) {
      const Rgb& c = cube.at(face, x, y);
      img.pixels.insert(img.pixels.end(), {float(c.r), float(c.g), float(c.b)});
    }
  }
  img.metadata["kiln:content"] = what;
  img.metadata["kiln:face"] = std::string(kFaceNames[face]);
  img.metadata["kiln:cubemap_convention"] = std::string(kCubemapConvention);
  img.metadata["kiln:equirect_convention"] = std::string(kEquirectConvention);
  return img;
}

// The state a bake carries from stage to stage; each stage releases what the later ones no longer need.
struct EnvironmentRun {
  const EnvironmentBakeInput& in;
  const bake::BakeControl& control;
  EnvironmentBakeResult result;
  std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now(), stage_start = start;
  bool from_faces = false;
  int levels = 0;
  std::string color_space = "lin_rec709";
  Cubemap source;                       // the source stage's cube; empty after the sun split
  SunSplit split;                       // sky and sun; empty after the diffuse stage
  std::vector<PrefilteredLevel> chain;  // the specular levels
  Cubemap irradiance;
  ShCoefficients sh{};
  std::shared_ptr<const DfgTable> dfg;  // shared with the process's cache (dfg_cache.h)

  EnvironmentRun(const EnvironmentBakeInput& input, const bake::BakeControl& bake_control)
      : in(input),
        control(bake_control),
        from_faces(!input.constant && !input.faces.empty()),
        levels(input.levels == 0 ? default_levels(input.size) : input.levels) {}

  // Ends a stage: records its time, honours a cancel request and reports progress.
  void end_stage(double fraction, const std::string& stage) {
    const auto now = std::chrono::steady_clock::now();
    result.stage_seconds.push_back({stage, std::chrono::duration<double>(now - stage_start).count()});
    stage_start = now;
    if (control.cancel && control.cancel->load()) throw bake::BakeCancelled();
    if (!control.progress) return;
    bake::BakeProgress p;
    p.fraction = fraction;
    p.samples = result.samples;
    p.stage = stage;
    for (double e : result.level_error) p.error_estimate = std::max(p.error_estimate, e);
    control.progress(p);
  }

  void plan(EnvironmentEffect effect, bool enabled, bool forced, const std::string& reason) {
    const std::string name(effect_name(effect));
    result.plan_entries.push_back({name, enabled, forced, reason});
    result.plan.push_back(name + ": " + (enabled ? "on" : "off") + (forced ? " (forced)" : "") + " - " + reason);
  }

  void add_output(std::string name, std::string media_type, std::string space, std::string bytes) {
    result.outputs.push_back({std::move(name), std::move(media_type), std::move(space), std::move(bytes)});
  }
};

// Memory, from the headers alone: refused above kMaxEnvironmentMemory before anything large is allocated.
void check_memory(EnvironmentRun& run) {
  const EnvironmentBakeInput& in = run.in;
  EnvImageHeader header;
  if (!in.constant) header = run.from_faces ? probe_cube_faces(in.faces) : probe_environment(in.image);
  run.result.memory_bytes = estimate_environment_memory(in, header.width, header.height, run.from_faces);
  if (run.result.memory_bytes <= kMaxEnvironmentMemory) return;
  const std::string what = in.constant ? std::string("a constant")
                           : run.from_faces
                               ? "faces (6 x " + std::to_string(header.width) + "^2)"
                               : "image (" + std::to_string(header.width) + "x" + std::to_string(header.height) + ")";
  // The field is the source whose size is at fault; the problem keeps naming both it and `size`, either of which
  // the job can lower.
  const std::string source = run.from_faces ? "faces" : "image";
  throw bake::InvalidInput(
      source, "size, " + source + ": baking " + what + " to a " + std::to_string(in.size) + "^2 cube needs about " +
                  format_number(run.result.memory_bytes / double(1 << 30)) +
                  " GiB of working memory, more than the 4 GiB bound; lower size or upload a smaller "
                  "environment");
}

// ", rotated R deg about +Y, intensity I, resampled to a N^2 cube": how a decoded source became the source cube.
std::string resampling_description(const EnvironmentBakeInput& in) {
  return ", rotated " + format_number(in.decode.rotation_degrees) + " deg about +Y, intensity " +
         format_number(in.decode.intensity) + ", resampled to a " + std::to_string(in.size) + "^2 cube";
}

// The source cube in the working space.
void decode_source(EnvironmentRun& run) {
  const EnvironmentBakeInput& in = run.in;
  if (in.constant) {
    run.source = Cubemap(in.size, *in.constant);
    run.plan(EnvironmentEffect::source, true, false, "a constant environment " + bake::format_rgb(*in.constant));
  } else if (run.from_faces) {
    CubeFacesInput faces = decode_cube_faces(in.faces, in.decode);
    run.result.sanitized = faces.sanitized;
    run.color_space = faces.working_space;
    run.source = faces_to_cube(faces, in.size);
    run.plan(EnvironmentEffect::source, true, false,
             "six " + faces.format + " faces " + std::to_string(faces.face_size) + "^2 in " + faces.color_space +
                 resampling_description(in));
  } else {
    const EnvironmentInput env = decode_environment(in.image, in.decode);
    run.result.sanitized = env.sanitized;
    run.color_space = env.working_space;
    run.source = environment_to_cube(env, in.size);
    run.plan(EnvironmentEffect::source, true, false,
             "equirectangular " + env.format + " " + std::to_string(env.width) + "x" + std::to_string(env.height) +
                 " in " + env.color_space + resampling_description(in));
  }
  run.end_stage(0.1, "source");
}

// The sun as an explicit light (sun.h); the source is not needed after the split (sky + sun = source).
void split_sun_light(EnvironmentRun& run) {
  const auto forced = run.in.force_effects.find(std::string(effect_name(EnvironmentEffect::sun_light)));
  const SunMode mode = forced == run.in.force_effects.end() ? SunMode::automatic
                       : forced->second                     ? SunMode::forced_on
                                                            : SunMode::forced_off;
  run.split = split_sun(run.source, mode);
  run.source = Cubemap();
  EnvironmentBakeResult& result = run.result;
  result.sun_found = run.split.enabled;
  result.sun_texels = static_cast<int>(run.split.sun.size());
  result.sun_power_fraction = run.split.enabled ? run.split.power_fraction : 0.0;
  if (!run.split.enabled) run.split.sun.clear();
  run.plan(EnvironmentEffect::sun_light, run.split.enabled, mode != SunMode::automatic, run.split.reason);
  run.end_stage(0.15, "sun");
}

std::string samples_description(const EnvironmentBakeInput& in) {
  if (in.samples != 0) {
    return "fixed by the job: " + std::to_string(in.samples) + " per texel (rounded up to a multiple of 4)";
  }
  return "per level, the smallest tried N whose error against brute force on a checked subset of texels meets "
         "target_error " +
         format_number(in.target_error) + " (from 64, scaled by the 1/sqrt(N) law; within [16, 65536])";
}

// The specular chain, and each level's figures in the result.
void prefilter_chain(EnvironmentRun& run) {
  const EnvironmentBakeInput& in = run.in;
  PrefilterOptions options;
  options.levels = run.levels;
  options.samples = in.samples;
  options.target_error = in.target_error;
  options.distribution = lobe_distribution(in.lobe);
  options.seed = in.seed;
  options.cancel = run.control.cancel;
  run.plan(EnvironmentEffect::lobe, true, false, lobe_description(in.lobe));
  run.plan(EnvironmentEffect::samples, true, false, samples_description(in));
  run.chain = prefilter_specular(run.split.sky, run.split.sun, in.size, options);
  EnvironmentBakeResult& result = run.result;
  for (const PrefilteredLevel& l : run.chain) {
    result.level_roughness.push_back(l.roughness);
    result.level_error.push_back(l.error_estimate);
    result.level_samples.push_back(l.samples);
    result.levels.push_back(
        {l.cube.size(), l.roughness, l.samples, l.error_estimate, l.noise_estimate, l.checked_error, l.seconds});
    result.samples += static_cast<uint64_t>(l.samples) * 6 * l.cube.size() * l.cube.size() +
                      static_cast<uint64_t>(l.pilot_samples) * l.checked_texels;
  }
  run.end_stage(0.6, "specular");
}

// Diffuse: the irradiance cube by convolution of a downsampled sky plus the exact sun; the SH of the full sky plus
// the sun texels' exact projections.
void convolve_diffuse(EnvironmentRun& run) {
  run.irradiance = irradiance_with_sun(run.split.sky, run.split.sun, run.in.irradiance_size, kIrradianceSourceSize);
  run.sh = sh_radiance_to_irradiance(project_sh_with_sun(run.split.sky, run.split.sun));
  run.split = SunSplit();  // the sky and its sun are no longer needed
  run.end_stage(0.7, "irradiance");
}

// The DFG table of the same lobe, from the process or the store when an earlier bake computed the same one.
void compute_dfg_table(EnvironmentRun& run) {
  const EnvironmentBakeInput& in = run.in;
  brdf::AlbedoOptions options;
  options.samples = in.dfg_samples;
  options.seed = in.seed;
  DfgSource source = DfgSource::computed;
  run.dfg = cached_dfg(in.lobe, dfg_masking(in.lobe, in.dfg_masking), in.dfg_size, options, &source);
  run.result.dfg_table = to_string(source);
  run.result.samples += static_cast<uint64_t>(in.dfg_size) * in.dfg_size * in.dfg_samples;
  run.end_stage(0.85, "dfg");
}

// An output whose bytes are still to be encoded: the outputs stage gathers them all, then encodes them in parallel.
struct PendingOutput {
  std::string name, media_type, space;
  std::function<std::string()> encode;
};
using PendingOutputs = std::vector<PendingOutput>;

// specular.ktx2: every level and face, RGBA16F, with the conventions in its key/value data.
std::string specular_ktx2(const EnvironmentRun& run) {
  image::Ktx2Image ktx;
  ktx.width = ktx.height = run.in.size;
  ktx.faces = 6;
  ktx.levels = run.levels;
  ktx.format = image::Ktx2Image::rgba16f;
  ktx.data.resize(static_cast<size_t>(run.levels) * 6);
  std::string roughness;
  for (int k = 0; k < run.levels; ++k) {
    roughness += (k ? "," : "") + format_number(run.chain[k].roughness);
    for (int f = 0; f < 6; ++f) {
      std::vector<float>& px = ktx.image(k, f);
      for (const Rgb& c : run.chain[k].cube.face(f)) px.insert(px.end(), {float(c.r), float(c.g), float(c.b), 1.0f});
    }
  }
  const EnvLobe lobe = run.in.lobe;
  ktx.key_values["KTXorientation"] = "rd";
  ktx.key_values["kiln:roughness_per_level"] = roughness;
  ktx.key_values["kiln:roughness_mapping"] = "perceptual roughness rho_k = k/(levels-1), alpha = rho^2";
  ktx.key_values["kiln:lobe"] = to_string(lobe);
  ktx.key_values["kiln:lobe_description"] = lobe_description(lobe);
  ktx.key_values["kiln:cubemap_convention"] = std::string(kCubemapConvention);
  ktx.key_values["kiln:equirect_convention"] = std::string(kEquirectConvention);
  ktx.key_values["kiln:color_space"] = run.color_space;
  return image::encode_ktx2(ktx);
}

// specular_L{k}_{face}.exr: the same levels as EXR faces.
void specular_faces(const EnvironmentRun& run, PendingOutputs& out) {
  for (int k = 0; k < run.levels; ++k)
    for (int f = 0; f < 6; ++f) {
      const std::string name = "specular_L" + std::to_string(k) + "_" + std::string(kFaceNames[f]) + ".exr";
      out.push_back({name, "image/x-exr", run.color_space, [&run, k, f] {
                       const PrefilteredLevel& level = run.chain[k];
                       const std::string what = "specular prefiltered (" + std::string(to_string(run.in.lobe)) +
                                                "), level " + std::to_string(k) + ", roughness " +
                                                format_number(level.roughness);
                       return image::encode_exr(face_image(level.cube, f, what));
                     }});
    }
}

// irradiance_{face}.exr and sh.txt.
void diffuse_outputs(const EnvironmentRun& run, PendingOutputs& out) {
  for (int f = 0; f < 6; ++f)
    out.push_back({"irradiance_" + std::string(kFaceNames[f]) + ".exr", "image/x-exr", run.color_space,
                   [&run, f] { return image::encode_exr(face_image(run.irradiance, f, "irradiance E(n), W/m^2")); }});
  out.push_back({"sh.txt", "text/plain", run.color_space, [&run] {
                   std::string sh_text = std::string(kShIrradianceHeader) + "\n";
                   for (const Rgb& c : run.sh)
                     sh_text += format_number(c.r) + " " + format_number(c.g) + " " + format_number(c.b) + "\n";
                   return sh_text;
                 }});
}

// dfg.exr: (μ, ρ) → scale, bias, energy.
std::string dfg_exr(const EnvironmentRun& run) {
  const int size = run.in.dfg_size;
  image::FloatImage image;
  image.width = image.height = size;
  image.channels = 3;
  image.channel_names = {"scale", "bias", "energy"};
  for (int j = 0; j < size; ++j) {
    for (int i = 0; i < size; ++i) {
      const DfgEntry& e = run.dfg->at(i, j);
      image.pixels.insert(image.pixels.end(), {float(e.scale), float(e.bias), float(e.energy)});
    }
  }
  image.metadata["kiln:axes"] =
      "x: mu = n.v = (x + 0.5)/width; y: perceptual roughness (y + 0.5)/height, alpha = rho^2";
  image.metadata["kiln:lobe"] = to_string(run.in.lobe);
  image.metadata["kiln:masking"] = brdf::to_string(dfg_masking(run.in.lobe, run.in.dfg_masking));
  image.metadata["kiln:channel.scale"] = "scale: the factor on f0 (E ~= f0 * scale + bias)";
  image.metadata["kiln:channel.bias"] = "bias: the term added";
  image.metadata["kiln:channel.energy"] = "scale + bias: the directional albedo with F = 1";
  return image::encode_exr(image);
}

void preview_output(EnvironmentRun& run, PendingOutputs& out) {
  if (!run.in.preview) {
    run.plan(EnvironmentEffect::preview, false, false, "not asked for");
    return;
  }
  out.push_back({"preview.png", "image/png", "",
                 [&run] { return render_preview(run.chain, run.irradiance, *run.dfg, run.color_space); }});
  run.plan(EnvironmentEffect::preview, true, false,
           "preview.png: spheres at roughness 0, 0.25, 0.5, 0.75, 1 and a diffuse one");
}

// Every output file is independent of the others, so all are encoded in parallel on the job's threads (zip
// compression of the EXR faces, the KTX2 file's half floats and the preview's rendering and PNG are the stage), one
// task each, then added in a fixed order: the same outputs, in the same order, as one by one.
void encode_outputs(EnvironmentRun& run) {
  PendingOutputs pending;
  pending.push_back({"specular.ktx2", "image/ktx2", run.color_space, [&run] { return specular_ktx2(run); }});
  specular_faces(run, pending);
  diffuse_outputs(run, pending);
  pending.push_back({"dfg.exr", "image/x-exr", "data", [&run] { return dfg_exr(run); }});
  preview_output(run, pending);
  std::vector<std::string> bytes(pending.size());
  tbb::parallel_for(
      tbb::blocked_range<size_t>(0, pending.size(), 1),
      [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i != r.end(); ++i) bytes[i] = pending[i].encode();
      },
      tbb::simple_partitioner());
  for (size_t i = 0; i < pending.size(); ++i) {
    PendingOutput& p = pending[i];
    run.add_output(std::move(p.name), std::move(p.media_type), std::move(p.space), std::move(bytes[i]));
  }
  run.end_stage(0.95, "outputs");
}

void write_report(EnvironmentRun& run) {
  run.result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - run.start).count();
  run.add_output("report.json", "application/json", "", environment_report_json(run.in, run.result, run.color_space));
}

}  // namespace

std::optional<bake::InvalidInput> validate(const EnvironmentBakeInput& in) {
  using bake::check_range;
  using bake::InvalidInput;
  if (!is_power_of_two(in.size) || !bounds::kCubeSize.contains(in.size)) {
    return InvalidInput("size", "must be a power of two in [" + std::to_string(bounds::kCubeSize.lo) + ", " +
                                    std::to_string(bounds::kCubeSize.hi) + "], got " + std::to_string(in.size));
  }
  if (in.levels != 0) {
    const bounds::Range levels{static_cast<double>(bounds::kLevels.lo), static_cast<double>(default_levels(in.size))};
    if (auto e = check_range("levels", in.levels, levels)) return e;
  }
  if (auto e = check_range("irradiance_size", in.irradiance_size, bounds::kIrradianceSize.real())) return e;
  if (auto e = check_range("dfg_size", in.dfg_size, bounds::kDfgSize.real())) return e;
  if (in.samples != 0) {
    if (auto e = check_range("samples", in.samples, bounds::kEnvironmentSamples.real())) return e;
  }
  if (auto e = check_range("dfg_samples", in.dfg_samples, bounds::kDfgSamples.real())) return e;
  if (in.dfg_masking) {
    if (auto problem = dfg_masking_problem(in.lobe, *in.dfg_masking)) return InvalidInput("dfg_masking", *problem);
  }
  if (auto e = check_range("target_error", in.target_error, bounds::kEnvironmentTargetError)) return e;
  if (in.constant) {
    if (auto e = bake::check_rgb("constant", *in.constant, bounds::kEnvironmentConstant)) return e;
  } else if (!in.faces.empty()) {
    if (in.faces.size() != 6) {
      return InvalidInput("faces", "a cube needs exactly 6 face images (+X, -X, +Y, -Y, +Z, -Z), got " +
                                       std::to_string(in.faces.size()));
    }
  } else if (in.image.empty()) {
    return InvalidInput("image", "no environment given (an image, six faces, or a constant colour)");
  }
  for (const auto& [name, on] : in.force_effects) {
    const std::optional<EnvironmentEffect> effect = effect_from_name(name);
    if (!effect || !forcible(*effect)) {
      return InvalidInput(
          "force_effects[" + name + "]",
          "unknown effect '" + name + "'; the effects that can be forced are: " + forcible_effect_names());
    }
  }
  return std::nullopt;
}

uint64_t estimate_environment_memory(const EnvironmentBakeInput& in, int width, int height, bool faces) {
  const double n2 = 6.0 * in.size * in.size;
  const double cube = n2 * sizeof(Rgb);        // C
  const double chain_texels = n2 * 4.0 / 3.0;  // T
  double source = cube;
  if (faces)
    source += 6.0 * width * width * sizeof(Rgb) + double(width) * width * 36.0;
  else
    source += double(width) * height * 60.0;
  const double split = 10.0 / 3.0 * cube;
  // The chain's working set, and the sampler's copy of the sky's mips with a one-texel border (4/3 C, padded).
  const double chain =
      11.0 / 3.0 * cube + 4.0 / 3.0 * cube * (in.size + 2.0) * (in.size + 2.0) / (double(in.size) * in.size);
  const double output = 4.0 / 3.0 * cube + chain_texels * 48.0 + 12.0 * in.size * in.size;
  const double small = 6.0 * kIrradianceSourceSize * kIrradianceSourceSize * sizeof(Rgb) * 2 +
                       6.0 * in.irradiance_size * in.irradiance_size * sizeof(Rgb) * 2 +
                       double(in.dfg_size) * in.dfg_size * (sizeof(DfgEntry) + 12.0) + (1 << 20);
  return static_cast<uint64_t>(std::max({source, split, chain, output}) + small);
}

uint64_t estimate_environment_job_memory(const EnvironmentBakeInput& in, uint64_t encoded_bytes, bool faces) {
  const double pixels = std::min<double>(static_cast<double>(encoded_bytes), double(uint64_t{1} << 26));
  int width = 0, height = 0;
  if (!in.constant && encoded_bytes > 0) {
    width = static_cast<int>(std::ceil(faces ? std::sqrt(pixels / 6) : std::sqrt(2 * pixels)));
    height = faces ? width : (width + 1) / 2;
  }
  return std::min(estimate_environment_memory(in, width, height, faces), kMaxEnvironmentMemory) + encoded_bytes;
}

EnvironmentBakeResult bake_environment(const EnvironmentBakeInput& in, const bake::BakeControl& control) {
  if (auto problem = validate(in)) throw *problem;
  EnvironmentRun run(in, control);
  check_memory(run);
  decode_source(run);
  split_sun_light(run);
  prefilter_chain(run);
  convolve_diffuse(run);
  compute_dfg_table(run);
  encode_outputs(run);
  write_report(run);
  run.end_stage(1.0, "done");
  return std::move(run.result);
}

}  // namespace kiln::envmap
