// The lightmap bake, assembled: a scene in; per lightmap the irradiance, validity and estimated-error images (and on
// request radiance, ambient occlusion and a directional term), a preview and a report out. Plain C++ types: the
// daemon translates its messages into LightmapBakeInput.
//
// Outputs (names fixed), for each lightmap NAME (a mesh's name, or an atlas named by instances, made a safe and unique
// file stem by the scene check: scene/lightmap_file_names.h):
//   NAME_irradiance.exr   RGB float32, scene-linear, irradiance E in W·m⁻², dilated by `padding` texels
//   NAME_validity.exr     1 valid, 0 invalid, before dilation
//   NAME_error.exr        the estimated relative error per texel
//   NAME_irradiance_denoised.exr  the irradiance through the denoiser (denoise.h), dilated likewise (on request)
//   NAME_radiance.exr     ρE/π (on request)        NAME_ao.exr  ambient occlusion (on request); both dilated
// The irradiance (raw and denoised), radiance, AO and preview are stitched along seams after dilation (seams.h).
//   NAME_sh.exr           order-1 SH of incoming radiance, 4 RGB coefficients as 12 channels (on request)
//   NAME_preview.png      the irradiance through OpenColorIO's display transform
//   report.json           plan, samples, rays, time, error estimate, error-versus-time curve, scene problems, memory
//   lightmaps.json        when atlas.texel_density is set: each instance's page, scale and offset (lightmap_manifest.h)
//   MESH_uv.bin           per mesh that got generated lightmap UVs (lightmap_uvgen.h): the mesh with them, in the kiln
//                         mesh layout
//   probes.vdb, probes_preview.png  when `probes` is enabled: light probes of the same scene (probe_outputs.h), baked
//                         after the lightmaps, before report.json (whose "probes" object describes them)
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "bakers/bake/cancelled.h"
#include "bakers/bake/control.h"
#include "bakers/bake/invalid_input.h"
#include "bakers/bake/output.h"
#include "bakers/envmap/env_input.h"
#include "bakers/lightmap/atlas_pack.h"
#include "bakers/lightmap/denoise.h"
#include "bakers/lightmap/error_metric.h"
#include "bakers/lightmap/memory_estimate.h"
#include "bakers/lightmap/probe_volume.h"
#include "bakers/plan/decision.h"
#include "bakers/scene/scene.h"
#include "bakers/uvgen/uv_generator.h"
#include "bakers/volume/medium_input.h"

namespace kiln::lightmap {

class RayLog;

inline constexpr const char* kLightmapBakerVersion = "kiln-lightmap-10";

// A texture as uploaded: decoded by the bake (OpenImageIO) into scene.textures, in this order.
struct EncodedTexture {
  std::string name;
  std::string bytes;
  std::string color_space;  // empty: srgb_texture for 8-bit formats, lin_rec709 for float ones
};

struct LightmapBakeInput {
  // The scene. Its `textures` must be empty when `textures` below is given (they are decoded into it); its
  // environment is filled from `environment_image` when that is not empty.
  scene::Scene scene;
  std::vector<EncodedTexture> textures;
  std::string environment_image;  // an encoded equirectangular image, or empty
  envmap::EnvDecodeOptions environment_decode;
  // Participating media (docs/MEDIA.md), at most bounds::kLightmapMedia.hi; their coefficients add where they
  // overlap. Grid media hold their grids, read from the VDB blob before the bake.
  std::vector<volume::MediumInput> media;

  int resolution = 256;                    // texels on a side of every lightmap, [4, 8192]
  std::map<std::string, int> resolutions;  // per lightmap name, overriding `resolution`
  int padding = 4;                         // texels of dilation, [0, 64]
  // Atlas pages (atlas_pack.h): with atlas.texel_density > 0 every baking instance gets a region of a page at that
  // density, replacing its own lightmap name and lightmap_scale_offset; pages are atlas.page_size on a side
  // (`resolution` and `resolutions` do not apply), charts are `padding` texels apart (at least 2; atlas.padding is
  // not read) and lightmaps.json is written. 0: no packing, each instance bakes where the scene puts it.
  AtlasOptions atlas;
  // Lightmap UVs generated (lightmap_uvgen.h) for the meshes whose own are unusable (automatic: none, outside
  // [0, 1], or overlapping themselves), for every mesh (always) or for none (never); NAME_uv.bin holds each generated
  // mesh and report.json's generated_uvs its charts and quality.
  uvgen::GenerateUvs generate_uvs = uvgen::GenerateUvs::automatic;

  double target_error = 0.01;  // the error per texel, under error_metric, the adaptive sampling aims at
  ErrorMetric error_metric = ErrorMetric::lightmap;  // what target_error measures (error_metric.h)
  uint64_t min_samples = 16;                         // per texel before any texel may stop, [1, max_samples]
  uint64_t max_samples = 4096;                       // per texel, [1, 1 << 20]
  double time_limit_seconds = 0;  // stop after this long (texels not yet reached keep what they have); 0: none
  uint64_t seed = 1;              // the same input and seed give the same bytes

  int max_bounces = 64;  // cap on the planner's bounce count, [0, 1024]
  std::map<std::string, bool> force_effects;
  // Ignore the planner: simulate every effect the scene has with max_bounces bounces (plan::full_plan). The
  // reference the planner's equivalence tests and benchmarks compare against; force_effects must then be empty.
  bool full_simulation = false;

  bool radiance = false;     // NAME_radiance.exr
  bool ao = false;           // NAME_ao.exr
  bool directional = false;  // NAME_sh.exr
  bool preview = true;       // NAME_preview.png
  bool denoise = false;      // NAME_irradiance_denoised.exr as well (denoise.h); NAME_irradiance.exr is unchanged
  // Stitch seams (seams.h): where one world edge lies on two chart borders, the texels the bilinear lookups on both
  // sides read are adjusted after dilation so that the lookups agree, in every image but the validity, error and SH.
  bool stitch_seams = true;
  // The denoiser's settings: benchmarks tune them; a job always has the defaults (so they are not in the cache key).
  DenoiseOptions denoise_options;

  // The peak memory the bake may hold, in bytes (0: no limit). A bake whose estimate (memory_estimate.h, the model
  // the daemon checks jobs against) exceeds it samples each page a tile at a time, in the largest tiles that fit
  // (plan_memory), holding only a tile's sampling state and a page's results (lightmap_results.h); light tracing is
  // then off. Tiles give the same answer as a whole page within the noise, not the same bytes.
  uint64_t memory_limit_bytes = 0;
  // Light probes of the same scene (probe_volume.h), sampled to target_error under error_metric with min_samples to
  // max_samples estimates each, after the lightmaps; every probe gets min_samples whatever the time limit.
  ProbeVolumeOptions probes;
  // false: no lightmap, only the probes (a probes job): meshes need no lightmap UVs, and probes must be enabled.
  bool lightmaps = true;

  // Tests and benchmarks only, not part of a job: tiles of this many texels on a side whatever the memory limit
  // says, [kMinTileSize, 16384]; 0: as the memory limit decides.
  int tile_size = 0;

  // Benchmarks only, not part of a job (the service never sets it, and it is not in the cache key): receives the
  // rays the transport and the leak probes trace (ray_log.h).
  RayLog* ray_log = nullptr;
};

// One point of the error-versus-time curve: after a pass, the estimate over all valid texels; in a tiled bake after a
// tile, over the valid texels of the tiles done so far (the last point: over every texel of every page).
struct ErrorPoint {
  double seconds = 0;
  uint64_t samples = 0;
  double error = 0;  // RMS over valid texels of the estimated error under the input's error_metric
};

// What light tracing did (light_tracing.h), when the plan has it.
struct LightTracingStats {
  bool on = false;
  uint64_t rays = 0;           // closest-hit queries of rays from the lights (also counted in `rays`)
  uint64_t light_rays = 0;     // rays started at the lights
  uint64_t deposits = 0;       // into traced texels
  size_t texels_traced = 0;    // whose indirect light came from light tracing
  size_t texels_gathered = 0;  // valid texels that gathered all their light
  double seconds = 0;
};

struct LightmapBakeResult {
  // In the order of the table above: each lightmap's images, lightmap by lightmap, then report.json. Empty when the
  // control's output_sink took them, one by one as each was encoded.
  std::vector<bake::BakeOutput> outputs;
  std::vector<plan::Decision> plan;
  std::vector<ErrorPoint> curve;
  uint64_t samples = 0, rays = 0;
  uint64_t occlusion_rays = 0;  // of `rays`, the shadow (any-hit) queries; the others are closest-hit
  uint64_t probe_rays = 0;      // of the closest-hit ones, the leak probes' (leaks.h), traced before the passes
  // Path vertices shaded through the general BSDF (a glossy or otherwise non-Lambertian material); the others are
  // shaded in closed Lambertian form (integrator.h), which is what pruning a glossy lobe buys.
  uint64_t general_vertices = 0;
  double seconds = 0;
  // The last point of the curve; −1 (unknown) when no texel has an estimate of its error, as when the time limit
  // ended the bake before its first sample: never 0 for want of samples.
  double error_estimate = -1;
  LightTracingStats light_tracing;
  // How the bake held its memory (memory_estimate.h): untiled or in tiles, the estimate it planned by, and the peak
  // of what it held in its texel state and page results (the tracer and scene aside).
  struct Memory {
    uint64_t limit_bytes = 0;         // the input's memory_limit_bytes
    uint64_t estimate_bytes = 0;      // the estimate of the bake as it ran
    int tile_size = 0;                // 0: untiled
    uint64_t tiles = 0;               // tiles baked (with texels), over every page
    uint64_t tiles_unsampled = 0;     // of them, left out by the time limit's budget: rasterized, not sampled
    uint64_t held_peak_bytes = 0;     // the most texel state and page results (and seam system) held at once
    double bytes_per_texel_held = 0;  // of the texels in flight: their sampling state and sample points
  } memory;
  // How a tiled bake with a time limit divided it (tile_time_budget.h): when the last run of tiles it left unsampled
  // began (−1: it sampled the last tile), what was then forecast to follow (the tiles left rasterized, the pages
  // left written) and what that took; and the rates the budget forecast by at the end.
  struct TimeBudget {
    bool on = false;
    double sampling_ended_seconds = -1;
    double forecast_seconds = 0, after_seconds = 0;
    double sampled_rate = 0;     // s per texel² covered: a sampled tile but for its passes
    double first_pass_rate = 0;  // s per texel² covered: a sampled tile's first pass
    double unsampled_rate = 0;   // s per texel² covered: an unsampled tile, whole
    double output_rate = 0;      // s per page texel: a page's outputs
  } time_budget;
  std::vector<std::string> skipped;  // scene problems: what was not baked and why, for people
};

// nullopt if valid, else the first offending field and what is wrong with it.
std::optional<bake::InvalidInput> validate(const LightmapBakeInput& input);

// The memory estimate's size of the outputs `input` asks for (no texels, triangles or bytes yet); `streamed`: the
// outputs go to BakeControl::output_sink as they are made.
LightmapJobSize output_size(const LightmapBakeInput& input, bool streamed);

// Throws bake::InvalidInput for a bad input: a field out of range (validate()), bytes that do not decode (field
// "textures[I]", I the index in `textures`, or "environment_image"; the problem is the decoder's message, which
// names the texture), or a scene with nothing to bake (an empty field). Throws bake::BakeCancelled when cancelled.
LightmapBakeResult bake_lightmaps(const LightmapBakeInput& input, const bake::BakeControl& control = {});

}  // namespace kiln::lightmap
