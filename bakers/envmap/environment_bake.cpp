#include "bakers/envmap/environment_bake.h"

#include <chrono>
#include <cmath>
#include <sstream>

#include "bakers/brdf/describe.h"
#include "bakers/envmap/cubemap.h"
#include "bakers/envmap/dfg.h"
#include "bakers/envmap/irradiance.h"
#include "bakers/envmap/prefilter.h"
#include "bakers/envmap/sh.h"
#include "bakers/image/exr.h"
#include "bakers/image/ktx2.h"

namespace kiln::envmap {
namespace {

using brdf::format_number;

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
  return img;
}

void check_cancel(const material::BakeControl& control) {
  if (control.cancel && control.cancel->load()) throw material::BakeCancelled();
}

}  // namespace

const char* to_string(EnvLobe lobe) {
  switch (lobe) {
    case EnvLobe::ggx: return "ggx";
    case EnvLobe::beckmann: return "beckmann";
    case EnvLobe::cook_torrance: return "cook_torrance";
    case EnvLobe::schlick: return "schlick";
  }
  return "unknown";
}

std::optional<EnvLobe> env_lobe_from_string(const std::string& name) {
  for (EnvLobe l : {EnvLobe::ggx, EnvLobe::beckmann, EnvLobe::cook_torrance, EnvLobe::schlick}) {
    if (name == to_string(l)) return l;
  }
  return std::nullopt;
}

std::optional<std::string> validate(const EnvironmentBakeInput& in) {
  auto range = [](const char* field, double v, double lo, double hi) -> std::optional<std::string> {
    if (std::isfinite(v) && v >= lo && v <= hi) return std::nullopt;
    return std::string(field) + ": must be in [" + format_number(lo) + ", " + format_number(hi) + "], got " +
           format_number(v);
  };
  if (!is_power_of_two(in.size) || in.size < 4 || in.size > 2048) {
    return "size: must be a power of two in [4, 2048], got " + std::to_string(in.size);
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
  if (in.constant) {
    for (int c = 0; c < 3; ++c) {
      if (auto e = range("constant", (*in.constant)[c], 0.0, 1e6)) return e;
    }
  } else if (in.image.empty()) {
    return "image: no environment given (an image, or a constant colour)";
  }
  return std::nullopt;
}

EnvironmentBakeResult bake_environment(const EnvironmentBakeInput& in, const material::BakeControl& control) {
  if (auto problem = validate(in)) throw std::invalid_argument(*problem);
  const auto t0 = std::chrono::steady_clock::now();
  EnvironmentBakeResult result;
  auto progress = [&](double fraction, const std::string& stage) {
    check_cancel(control);
    if (!control.progress) return;
    material::BakeProgress p;
    p.fraction = fraction;
    p.samples = result.samples;
    p.stage = stage;
    control.progress(p);
  };

  // 1. The source cube in the working space.
  Cubemap source(in.size);
  std::string color_space = "lin_rec709";
  if (in.constant) {
    source = Cubemap(in.size, *in.constant);
    result.plan.push_back("source: a constant environment " + brdf::format_rgb(*in.constant));
  } else {
    const EnvironmentInput env = decode_environment(in.image, in.decode);
    result.sanitized = env.sanitized;
    color_space = env.working_space;
    source = environment_to_cube(env, in.size);
    result.plan.push_back("source: " + env.format + " " + std::to_string(env.width) + "x" +
                          std::to_string(env.height) + " in " + env.color_space + ", resampled to a " +
                          std::to_string(in.size) + "^2 cube");
  }
  progress(0.1, "source");

  // 2. The specular chain.
  const int levels = in.levels == 0 ? default_levels(in.size) : in.levels;
  PrefilterOptions options;
  options.levels = levels;
  options.samples = in.samples == 0 ? 64 : in.samples;  // TODO(issue 4): from target_error
  const std::vector<PrefilteredLevel> chain = prefilter_specular(source, in.size, options);
  for (const PrefilteredLevel& l : chain) {
    result.level_roughness.push_back(l.roughness);
    result.level_error.push_back(l.error_estimate);
    result.samples += static_cast<uint64_t>(options.samples) * 6 * l.cube.size() * l.cube.size();
  }
  progress(0.6, "specular");

  // 3. Diffuse: the irradiance cube by convolution of a downsampled source, and the SH of the full source.
  Cubemap small = source;
  while (small.size() > kIrradianceSourceSize) small = downsample_2x(small);
  const Cubemap irradiance = irradiance_cubemap(small, in.irradiance_size);
  const ShCoefficients sh = sh_radiance_to_irradiance(project_sh(source));
  progress(0.7, "irradiance");

  // 4. The DFG table of the GGX lobe.
  brdf::ModelSpec ggx;
  ggx.model = brdf::Model::ggx;
  brdf::AlbedoOptions dfg_options;
  dfg_options.samples = in.dfg_samples;
  const DfgTable dfg = compute_dfg(ggx, in.dfg_size, in.dfg_size, dfg_options);
  result.samples += static_cast<uint64_t>(in.dfg_size) * in.dfg_size * in.dfg_samples;
  progress(0.9, "dfg");

  // 5. Outputs.
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
                                image::encode_exr(face_image(cube, f, "specular prefiltered, level " +
                                                                          std::to_string(k) + ", roughness " +
                                                                          format_number(chain[k].roughness)))});
    }
  }
  ktx.key_values["KTXorientation"] = "rd";
  ktx.key_values["kiln:roughness_per_level"] = roughness.str();
  ktx.key_values["kiln:roughness_mapping"] = "perceptual roughness rho_k = k/(levels-1), GGX alpha = rho^2";
  ktx.key_values["kiln:lobe"] = "ggx, n = v = r, weighted by n.l";
  ktx.key_values["kiln:cubemap_convention"] = std::string(kCubemapConvention);
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
  result.outputs.push_back({"dfg.exr", "image/x-exr", "data", image::encode_exr(dfg_image)});

  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::ostringstream json;
  json << "{\n  \"baker\": \"kiln environment (in progress)\",\n  \"size\": " << in.size << ",\n  \"levels\": [";
  for (int k = 0; k < levels; ++k) {
    json << (k ? ", " : "") << "{\"roughness\": " << format_number(chain[k].roughness)
         << ", \"error_estimate\": " << format_number(chain[k].error_estimate) << "}";
  }
  json << "],\n  \"samples\": " << result.samples << ",\n  \"seconds\": " << format_number(result.seconds)
       << ",\n  \"sanitized\": {\"nan\": " << result.sanitized.nan << ", \"inf\": " << result.sanitized.inf
       << ", \"negative\": " << result.sanitized.negative << "},\n  \"color_space\": \"" << color_space << "\"\n}\n";
  result.outputs.push_back({"report.json", "application/json", "", json.str()});
  progress(1.0, "done");
  return result;
}

}  // namespace kiln::envmap
