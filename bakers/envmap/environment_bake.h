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
//   dfg.exr                           (μ, ρ) table: scale, bias, energy, with the masking it used (kiln:masking)
//   preview.png                       (if asked) spheres at several roughnesses, display-transformed (preview.h)
//   report.json                       samples (total, per level), time (total, per stage), estimated error per
//                                     level, the plan (effects with enabled/forced/reason), conventions, colour
//                                     space, memory, sanitised counts
//
// ## Memory (estimated before anything large is allocated; refused above kMaxEnvironmentMemory)
// With C = 6 N² · 24 bytes (one cube of doubles at the output size N) and T = 6 N² · 4/3 texels in the chain:
//   source stage    equirect W·H·60 bytes (decoded floats 12, image 24, rotated copy 24) + C;
//                   or faces: 6 M²·24 (the faces as a cube) + M²·36 (one face decoding) + C
//   split stage     3.33 C (source, sky, and the per-texel luminance, solid angle and order of the sun rule)
//   chain stage     5 C (sky, its mip chain 4/3 C and its padded copy for the sampler 4/3 C, the chain 4/3 C)
//   output stage    4/3 C + T·48 (KTX floats 16 and bytes 8, EXR bytes ≤ 12, ... per texel) + 12 N² per face
// plus the irradiance, DFG and preview (small), and the peak is the largest stage. 4 GiB admits every size up to
// 2048 with equirect images up to ~61 M pixels (e.g. 11000 × 5500); env_input's own limit is 2^26 = 67 M pixels.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "bakers/bake/cancelled.h"
#include "bakers/bake/control.h"
#include "bakers/bake/invalid_input.h"
#include "bakers/bake/output.h"
#include "bakers/envmap/env_input.h"
#include "bakers/envmap/lobe.h"  // EnvLobe

namespace kiln::envmap {

inline constexpr const char* kEnvironmentBakerVersion = "kiln-environment-3";

struct EnvironmentBakeInput {
  // Exactly one source: `constant`, else six `faces`, else `image`.
  std::string image;               // an encoded equirectangular environment (EXR, HDR, PNG, JPEG)
  std::vector<std::string> faces;  // or six encoded square faces, in the order +X, −X, +Y, −Y, +Z, −Z (KTX/GL)
  std::optional<Rgb> constant;     // or a constant colour
  EnvDecodeOptions decode;         // colour space, rotation, intensity
  EnvLobe lobe = EnvLobe::ggx;
  int size = 128;            // specular cube face size, a power of two in [4, 2048]
  int levels = 0;            // mip levels; 0: every level down to 4×4
  int irradiance_size = 32;  // [1, 256]
  int dfg_size = 64;         // [2, 1024]
  // The DFG table's masking: unset, the lobe's default (height-correlated Smith for ggx, beckmann and schlick; the
  // V-groove G for cook_torrance, which takes no other); separable or height-correlated for the Smith lobes.
  std::optional<brdf::Masking> dfg_masking;
  // Prefilter samples per texel: 0 = chosen per level to reach target_error (within [16, 65536]); else [4, 65536].
  int samples = 0;
  double target_error = 0.01;  // relative error per level the sample count aims at, [1e-4, 1]
  int dfg_samples = 1024;      // per DFG entry, [16, 1 << 20]
  bool preview = true;         // also write preview.png (a sphere at several roughnesses, display-transformed)
  uint64_t seed = 1;           // the same input and seed give the same bytes
  // Effects forced on (true) or off (false) whatever the planner decides, by the names the report's plan uses
  // (environment_effect.h). Forcible: "sun_light" (on: use the sun split whenever a texel passes the threshold, and
  // say so when none does; off: the sun stays in the importance-sampled map; sun.h). Unknown names are an error.
  std::map<std::string, bool> force_effects;
};

inline constexpr uint64_t kMaxEnvironmentMemory = uint64_t{4} << 30;  // 4 GiB

// One decision of the bake's plan, for the effects of environment_effect.h.
struct EnvironmentPlanEntry {
  std::string effect;  // effect_name(): "source", "sun_light", "lobe", "samples", "preview"
  bool enabled = false;
  bool forced = false;  // set by force_effects
  std::string reason;
};

struct EnvironmentLevelReport {
  int size = 0;
  double roughness = 0;
  int samples = 0;            // per texel (0 for level 0)
  double error_estimate = 0;  // relative RMS, noise and filtering bias (prefilter.h)
  double noise_estimate = 0;
  double checked_error = 0;
  double seconds = 0;
};

struct EnvironmentBakeResult {
  std::vector<bake::BakeOutput> outputs;
  std::vector<double> level_roughness, level_error;
  std::vector<int> level_samples;  // per texel, per level (0 for level 0)
  std::vector<EnvironmentLevelReport> levels;
  SanitizeReport sanitized;
  double seconds = 0;
  std::vector<std::pair<std::string, double>> stage_seconds;  // "source", "sun", "specular", ... in order
  uint64_t samples = 0;                                       // prefilter (+ checks) and DFG samples
  uint64_t memory_bytes = 0;                                  // the estimated peak working memory (see above)
  std::string dfg_table;  // where the DFG table came from: dfg_cache.h's to_string(DfgSource)
  std::vector<std::string> plan;  // "effect: on|off[ (forced)] - reason", one per plan entry
  std::vector<EnvironmentPlanEntry> plan_entries;
  // The sun split (sun.h).
  bool sun_found = false;
  int sun_texels = 0;
  double sun_power_fraction = 0;
};

// The peak working memory of a bake (see above) of `input` whose source is W × H (equirect) or six M × M faces
// (source_is_faces, W = H = M); a constant source has W = H = 0.
uint64_t estimate_environment_memory(const EnvironmentBakeInput& input, int source_width, int source_height,
                                     bool source_is_faces);
// The same before the source is read, from its encoded size alone (for a daemon's admission): the source taken as
// one pixel per encoded byte (floats and 8-bit images alike compress to more than a byte a pixel), 2:1 (or six
// square faces), the estimate held within kMaxEnvironmentMemory (the bake refuses more once it reads the headers),
// plus the encoded bytes themselves.
uint64_t estimate_environment_job_memory(const EnvironmentBakeInput& input, uint64_t encoded_bytes, bool faces);

// nullopt if valid, else the first offending field and what is wrong with it.
std::optional<bake::InvalidInput> validate(const EnvironmentBakeInput& input);

// Throws bake::InvalidInput (naming the field; also when the estimated memory exceeds kMaxEnvironmentMemory),
// std::runtime_error (an undecodable image or face, naming it) or bake::BakeCancelled.
EnvironmentBakeResult bake_environment(const EnvironmentBakeInput& input, const bake::BakeControl& control = {});

}  // namespace kiln::envmap
