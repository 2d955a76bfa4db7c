// The environment bake, assembled: an HDR environment (an image or a constant colour) in; the prefiltered specular
// cube chain (KTX2 and EXR faces), the irradiance cube, order-2 SH irradiance, the DFG table and a report out.
// Plain C++ types: the daemon translates its messages into EnvironmentBakeInput.
//
// Outputs (names fixed):
//   specular.ktx2                     every level and face, RGBA16F, with key/value metadata (roughness per level,
//                                     lobe, conventions, colour space)
//   specular_L{k}_{px,nx,py,ny,pz,nz}.exr   the same levels as EXR faces, RGB float
//   irradiance_{px,...}.exr           the irradiance cube, by direct convolution (not from SH)
//   sh.txt                            nine RGB irradiance coefficients, with the basis in a header line
//   dfg.exr                           (μ, ρ) table: scale, bias, energy
//   report.json                       sizes, samples, time, estimated error per level, conventions, sanitising
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "bakers/envmap/env_input.h"
#include "bakers/material/material_bake.h"  // BakeControl, BakeOutput, BakeCancelled (shared by the bakers)

namespace kiln::envmap {

// The specular lobe of the prefiltered chain and of the DFG table (issue 4: "selectable from the BRDF library").
enum class EnvLobe { ggx, beckmann, cook_torrance, schlick };
const char* to_string(EnvLobe lobe);
std::optional<EnvLobe> env_lobe_from_string(const std::string& name);

inline constexpr const char* kEnvironmentBakerVersion = "kiln-environment-1";

struct EnvironmentBakeInput {
  // Exactly one source: `constant`, else six `faces`, else `image`.
  std::string image;               // an encoded equirectangular environment (EXR, HDR, PNG, JPEG)
  std::vector<std::string> faces;  // or six encoded square faces, in the order +X, −X, +Y, −Y, +Z, −Z (KTX/GL)
  std::optional<Rgb> constant;     // or a constant colour
  EnvDecodeOptions decode;         // colour space, rotation, intensity
  EnvLobe lobe = EnvLobe::ggx;
  int size = 128;                // specular cube face size, a power of two in [4, 2048]
  int levels = 0;                // mip levels; 0: every level down to 4×4
  int irradiance_size = 32;      // [1, 256]
  int dfg_size = 64;             // [2, 1024]
  // Prefilter samples per texel: 0 = chosen per level to reach target_error (within [16, 65536]); else [4, 65536].
  int samples = 0;
  double target_error = 0.01;    // relative error per level the sample count aims at, [1e-4, 1]
  int dfg_samples = 1024;        // per DFG entry, [16, 1 << 20]
  bool preview = true;           // also write preview.png (a sphere at several roughnesses, display-transformed)
  uint64_t seed = 1;             // the same input and seed give the same bytes
  // Effects forced on (true) or off (false) whatever the planner decides, by the names the report's plan uses
  // (e.g. "sun_light"). Unknown names are an error.
  std::map<std::string, bool> force_effects;
};

struct EnvironmentBakeResult {
  std::vector<material::BakeOutput> outputs;
  std::vector<double> level_roughness, level_error;
  SanitizeReport sanitized;
  double seconds = 0;
  uint64_t samples = 0;
  std::vector<std::string> plan;
};

// nullopt if valid, else "field: problem, got value".
std::optional<std::string> validate(const EnvironmentBakeInput& input);

// Throws std::invalid_argument (naming the field), std::runtime_error (an undecodable image) or
// material::BakeCancelled.
EnvironmentBakeResult bake_environment(const EnvironmentBakeInput& input, const material::BakeControl& control = {});

}  // namespace kiln::envmap
