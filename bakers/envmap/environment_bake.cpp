#include "bakers/envmap/environment_bake.h"

#include <algorithm>
#include <chrono>
#include <sstream>

#include "bakers/bake/number_format.h"
#include "bakers/bake/range_check.h"
#include "bakers/envmap/cubemap.h"
#include "bakers/envmap/dfg.h"
#include "bakers/envmap/environment_effect.h"
#include "bakers/envmap/environment_report.h"
#include "bakers/envmap/irradiance.h"
#include "bakers/envmap/prefilter.h"
#include "bakers/envmap/preview.h"
#include "bakers/envmap/sun.h"
#include "bakers/envmap/sh.h"
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

void check_cancel(const bake::BakeControl& control) {
  if (control.cancel && control.cancel->load()) throw bake::BakeCancelled();
}

}  // namespace

std::optional<bake::InvalidInput> validate(const EnvironmentBakeInput& in) {
  using bake::InvalidInput;
  const auto range = [](const char* field, double v, double lo, double hi) { return bake::check_range(field, v, lo, hi); };
  if (!is_power_of_two(in.size) || in.size < 4 || in.size > 2048) {
    return InvalidInput("size", "must be a power of two in [4, 2048], got " + std::to_string(in.size));
  }
  if (in.levels != 0) {
    if (auto e = range("levels", in.levels, 1, default_levels(in.size))) return e;
  }
  if (auto e = range("irradiance_size", in.irradiance_size, 1, 256)) return e;
  if (auto e = range("dfg_size", in.dfg_size, 2, 1024)) return e;
  if (in.samples != 0) {
    if (auto e = range("samples", in.samples, 4, 65536)) return e;
  }
  if (auto e = range("dfg_samples", in.dfg_samples, 16, 1 << 20)) return e;
  if (auto e = range("target_error", in.target_error, 1e-4, 1.0)) return e;
  if (in.constant) {
    for (int c = 0; c < 3; ++c) {
      if (auto e = range("constant", (*in.constant)[c], 0.0, 1e6)) return e;
    }
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
      return InvalidInput("force_effects[" + name + "]", "unknown effect '" + name +
                                                             "'; the effects that can be forced are: " +
                                                             forcible_effect_names());
    }
  }
  return std::nullopt;
}

uint64_t estimate_environment_memory(const EnvironmentBakeInput& in, int width, int height, bool faces) {
  const double n2 = 6.0 * in.size * in.size;
  const double cube = n2 * sizeof(Rgb);        // C
  const double chain_texels = n2 * 4.0 / 3.0;  // T
  double source = cube;
  if (faces) source += 6.0 * width * width * sizeof(Rgb) + double(width) * width * 36.0;
  else source += double(width) * height * 60.0;
  const double split = 10.0 / 3.0 * cube;
  const double chain = 11.0 / 3.0 * cube;
  const double output = 4.0 / 3.0 * cube + chain_texels * 48.0 + 12.0 * in.size * in.size;
  const double small = 6.0 * kIrradianceSourceSize * kIrradianceSourceSize * sizeof(Rgb) * 2 +
                       6.0 * in.irradiance_size * in.irradiance_size * sizeof(Rgb) * 2 +
                       double(in.dfg_size) * in.dfg_size * (sizeof(DfgEntry) + 12.0) + (1 << 20);
  return static_cast<uint64_t>(std::max({source, split, chain, output}) + small);
}

EnvironmentBakeResult bake_environment(const EnvironmentBakeInput& in, const bake::BakeControl& control) {
  if (auto problem = validate(in)) throw *problem;
  const auto t0 = std::chrono::steady_clock::now();
  auto stage_t0 = t0;
  EnvironmentBakeResult result;
  auto progress = [&](double fraction, const std::string& stage) {
    const auto now = std::chrono::steady_clock::now();
    result.stage_seconds.push_back({stage, std::chrono::duration<double>(now - stage_t0).count()});
    stage_t0 = now;
    check_cancel(control);
    if (!control.progress) return;
    bake::BakeProgress p;
    p.fraction = fraction;
    p.samples = result.samples;
    p.stage = stage;
    for (double e : result.level_error) p.error_estimate = std::max(p.error_estimate, e);
    control.progress(p);
  };
  auto plan = [&](EnvironmentEffect effect, bool enabled, bool forced, const std::string& reason) {
    const std::string name(effect_name(effect));
    result.plan_entries.push_back({name, enabled, forced, reason});
    result.plan.push_back(name + ": " + (enabled ? "on" : "off") + (forced ? " (forced)" : "") + " - " + reason);
  };

  // 0. Memory, from the headers alone.
  const bool from_faces = !in.constant && !in.faces.empty();
  EnvImageHeader header;
  if (!in.constant) header = from_faces ? probe_cube_faces(in.faces) : probe_environment(in.image);
  result.memory_bytes = estimate_environment_memory(in, header.width, header.height, from_faces);
  if (result.memory_bytes > kMaxEnvironmentMemory) {
    const std::string what = in.constant ? std::string("a constant") :
                             from_faces ? "faces (6 x " + std::to_string(header.width) + "^2)" :
                                          "image (" + std::to_string(header.width) + "x" + std::to_string(header.height) + ")";
    throw std::invalid_argument("size, " + std::string(from_faces ? "faces" : "image") + ": baking " + what +
                                " to a " + std::to_string(in.size) + "^2 cube needs about " +
                                format_number(result.memory_bytes / double(1 << 30)) +
                                " GiB of working memory, more than the 4 GiB bound; lower size or upload a smaller "
                                "environment");
  }

  // 1. The source cube in the working space.
  Cubemap source;
  std::string color_space = "lin_rec709";
  if (in.constant) {
    source = Cubemap(in.size, *in.constant);
    plan(EnvironmentEffect::source, true, false, "a constant environment " + bake::format_rgb(*in.constant));
  } else if (from_faces) {
    CubeFacesInput faces = decode_cube_faces(in.faces, in.decode);
    result.sanitized = faces.sanitized;
    color_space = faces.working_space;
    source = faces_to_cube(faces, in.size);
    plan(EnvironmentEffect::source, true, false,
         "six " + faces.format + " faces " + std::to_string(faces.face_size) + "^2 in " + faces.color_space +
             ", rotated " + format_number(in.decode.rotation_degrees) + " deg about +Y, intensity " +
             format_number(in.decode.intensity) + ", resampled to a " + std::to_string(in.size) + "^2 cube");
  } else {
    const EnvironmentInput env = decode_environment(in.image, in.decode);
    result.sanitized = env.sanitized;
    color_space = env.working_space;
    source = environment_to_cube(env, in.size);
    plan(EnvironmentEffect::source, true, false,
         "equirectangular " + env.format + " " + std::to_string(env.width) + "x" + std::to_string(env.height) +
             " in " + env.color_space + ", rotated " + format_number(in.decode.rotation_degrees) +
             " deg about +Y, intensity " + format_number(in.decode.intensity) + ", resampled to a " +
             std::to_string(in.size) + "^2 cube");
  }
  progress(0.1, "source");

  // 2. The sun as an explicit light (sun.h); the source is not needed after the split (sky + sun = source).
  const auto forced = in.force_effects.find(std::string(effect_name(EnvironmentEffect::sun_light)));
  const SunMode mode = forced == in.force_effects.end() ? SunMode::automatic
                       : forced->second                 ? SunMode::forced_on
                                                        : SunMode::forced_off;
  SunSplit split = split_sun(source, mode);
  source = Cubemap();
  result.sun_found = split.enabled;
  result.sun_texels = static_cast<int>(split.sun.size());
  result.sun_power_fraction = split.enabled ? split.power_fraction : 0.0;
  if (!split.enabled) split.sun.clear();
  plan(EnvironmentEffect::sun_light, split.enabled, mode != SunMode::automatic, split.reason);
  progress(0.15, "sun");

  // 3. The specular chain.
  const int levels = in.levels == 0 ? default_levels(in.size) : in.levels;
  PrefilterOptions options;
  options.levels = levels;
  options.samples = in.samples;
  options.target_error = in.target_error;
  options.distribution = lobe_distribution(in.lobe);
  options.seed = in.seed;
  options.cancel = control.cancel;
  plan(EnvironmentEffect::lobe, true, false, lobe_description(in.lobe));
  plan(EnvironmentEffect::samples, true, false,
       in.samples == 0 ? "per level, the smallest tried N whose error against brute force on a checked subset of "
                         "texels meets target_error " + format_number(in.target_error) +
                         " (from 64, scaled by the 1/sqrt(N) law; within [16, 65536])"
                       : "fixed by the job: " + std::to_string(in.samples) + " per texel (rounded up to a multiple of 4)");
  std::vector<PrefilteredLevel> chain = prefilter_specular(split.sky, split.sun, in.size, options);
  for (const PrefilteredLevel& l : chain) {
    result.level_roughness.push_back(l.roughness);
    result.level_error.push_back(l.error_estimate);
    result.level_samples.push_back(l.samples);
    result.levels.push_back({l.cube.size(), l.roughness, l.samples, l.error_estimate, l.noise_estimate,
                             l.checked_error, l.seconds});
    result.samples += static_cast<uint64_t>(l.samples) * 6 * l.cube.size() * l.cube.size() +
                      static_cast<uint64_t>(l.pilot_samples) * l.checked_texels;
  }
  progress(0.6, "specular");

  // 4. Diffuse: the irradiance cube by convolution of a downsampled sky plus the exact sun; the SH of the full sky
  //    plus the sun texels' exact projections.
  Cubemap irradiance = irradiance_with_sun(split.sky, split.sun, in.irradiance_size, kIrradianceSourceSize);
  const ShCoefficients sh_radiance = project_sh_with_sun(split.sky, split.sun);
  const ShCoefficients sh = sh_radiance_to_irradiance(sh_radiance);
  split = SunSplit();  // the sky and its sun are no longer needed
  progress(0.7, "irradiance");

  // 5. The DFG table of the same lobe.
  brdf::AlbedoOptions dfg_options;
  dfg_options.samples = in.dfg_samples;
  dfg_options.seed = in.seed;
  const DfgTable dfg = compute_dfg(lobe_model(in.lobe), in.dfg_size, in.dfg_size, dfg_options);
  result.samples += static_cast<uint64_t>(in.dfg_size) * in.dfg_size * in.dfg_samples;
  progress(0.85, "dfg");

  // 6. Outputs.
  image::Ktx2Image ktx;
  ktx.width = ktx.height = in.size;
  ktx.faces = 6;
  ktx.levels = levels;
  ktx.format = image::Ktx2Image::rgba16f;
  ktx.data.resize(static_cast<size_t>(levels) * 6);
  std::ostringstream roughness;
  for (int k = 0; k < levels; ++k) {
    const Cubemap& cube = chain[k].cube;
    roughness << (k ? "," : "") << format_number(chain[k].roughness);
    for (int f = 0; f < 6; ++f) {
      std::vector<float>& px = ktx.image(k, f);
      for (const Rgb& c : cube.face(f)) px.insert(px.end(), {float(c.r), float(c.g), float(c.b), 1.0f});
      result.outputs.push_back({"specular_L" + std::to_string(k) + "_" + std::string(kFaceNames[f]) + ".exr",
                                "image/x-exr", color_space,
                                image::encode_exr(face_image(cube, f, "specular prefiltered (" +
                                                                          std::string(to_string(in.lobe)) +
                                                                          "), level " + std::to_string(k) +
                                                                          ", roughness " +
                                                                          format_number(chain[k].roughness)))});
    }
  }
  ktx.key_values["KTXorientation"] = "rd";
  ktx.key_values["kiln:roughness_per_level"] = roughness.str();
  ktx.key_values["kiln:roughness_mapping"] = "perceptual roughness rho_k = k/(levels-1), alpha = rho^2";
  ktx.key_values["kiln:lobe"] = to_string(in.lobe);
  ktx.key_values["kiln:lobe_description"] = lobe_description(in.lobe);
  ktx.key_values["kiln:cubemap_convention"] = std::string(kCubemapConvention);
  ktx.key_values["kiln:equirect_convention"] = std::string(kEquirectConvention);
  ktx.key_values["kiln:color_space"] = color_space;
  result.outputs.insert(result.outputs.begin(), {"specular.ktx2", "image/ktx2", color_space, image::encode_ktx2(ktx)});
  for (int f = 0; f < 6; ++f) {
    result.outputs.push_back({"irradiance_" + std::string(kFaceNames[f]) + ".exr", "image/x-exr", color_space,
                              image::encode_exr(face_image(irradiance, f, "irradiance E(n), W/m^2"))});
  }
  std::ostringstream sh_text;
  sh_text << kShIrradianceHeader << "\n";
  for (const Rgb& c : sh) sh_text << format_number(c.r) << " " << format_number(c.g) << " " << format_number(c.b) << "\n";
  result.outputs.push_back({"sh.txt", "text/plain", color_space, sh_text.str()});
  image::FloatImage dfg_image;
  dfg_image.width = dfg_image.height = in.dfg_size;
  dfg_image.channels = 3;
  dfg_image.channel_names = {"scale", "bias", "energy"};
  for (int j = 0; j < in.dfg_size; ++j) {
    for (int i = 0; i < in.dfg_size; ++i) {
      const DfgEntry& e = dfg.at(i, j);
      dfg_image.pixels.insert(dfg_image.pixels.end(), {float(e.scale), float(e.bias), float(e.energy)});
    }
  }
  dfg_image.metadata["kiln:axes"] = "x: mu = n.v = (x + 0.5)/width; y: perceptual roughness (y + 0.5)/height, alpha = rho^2";
  dfg_image.metadata["kiln:lobe"] = to_string(in.lobe);
  result.outputs.push_back({"dfg.exr", "image/x-exr", "data", image::encode_exr(dfg_image)});
  if (in.preview) {
    result.outputs.push_back({"preview.png", "image/png", "", render_preview(chain, irradiance, dfg, color_space)});
    plan(EnvironmentEffect::preview, true, false,
         "preview.png: spheres at roughness 0, 0.25, 0.5, 0.75, 1 and a diffuse one");
  } else {
    plan(EnvironmentEffect::preview, false, false, "not asked for");
  }
  progress(0.95, "outputs");

  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  result.outputs.push_back({"report.json", "application/json", "", environment_report_json(in, result, color_space)});
  progress(1.0, "done");
  return result;
}

}  // namespace kiln::envmap
