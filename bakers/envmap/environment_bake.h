// The environment bake, assembled: an HDR environment (an image or a constant colour) in; the prefiltered specular
// cube chain (KTX2 and EXR faces), the irradiance cube, order-2 SH irradiance, the DFG table and a report out.
// Plain C++ types: the daemon translates its messages into EnvironmentBakeInput (not yet wired: see issue 4).
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

#include <optional>
#include <string>
#include <vector>

#include "bakers/envmap/env_input.h"
#include "bakers/material/material_bake.h"  // BakeControl, BakeOutput, BakeCancelled (shared by the bakers)

namespace kiln::envmap {

struct EnvironmentBakeInput {
  std::string image;             // the encoded environment (EXR, HDR, PNG, JPEG); ignored if `constant` is set
  std::optional<Rgb> constant;   // a constant environment instead of an image
  EnvDecodeOptions decode;       // colour space, rotation, intensity
  int size = 128;                // specular cube face size, a power of two in [4, 2048]
  int levels = 0;                // mip levels; 0: every level down to 4×4
  int irradiance_size = 32;      // [1, 256]
  int dfg_size = 64;             // [2, 1024]
  int samples = 64;              // prefilter samples per texel, [4, 65536]
  int dfg_samples = 1024;        // per DFG entry, [16, 1 << 20]
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
