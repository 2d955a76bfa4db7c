// report.json of the lightmap bake: the plan, the samples and rays, the time and each stage's share of it, the error
// estimate (null when unknown: no texel was sampled) and its curve over the passes, per lightmap its texels, error,
// leaks and memory, whether it was denoised and how, the tracer's size and the scene's problems.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "bakers/lightmap/denoise.h"
#include "bakers/lightmap/leak_scope.h"
#include "bakers/lightmap/leaks.h"
#include "bakers/lightmap/lightmap_bake.h"
#include "bakers/lightmap/lightmap_image.h"
#include "bakers/lightmap/lightmap_outputs.h"
#include "bakers/lightmap/lightmap_uvgen.h"
#include "bakers/lightmap/memory.h"
#include "bakers/lightmap/stage_timer.h"
#include "bakers/lightmap/seams.h"
#include "bakers/plan/lightmap_plan.h"

namespace kiln::lightmap {

// One lightmap's entry.
struct LightmapReportEntry {
  std::string name;        // the file stem of its outputs (scene/lightmap_file_names.h)
  std::string input_name;  // the name the job gave it, when it differs from `name`
  int resolution = 0;
  LightmapImage::ErrorSummary error;
  std::optional<ShError> sh;  // when the SH output was asked for
  LeakReport leaks;
  LightmapMemory memory;
  std::optional<SeamReport> seams;  // when seams were stitched
};

// What the report says beside the bake's result.
struct LightmapReport {
  double target_error = 0;
  ErrorMetric error_metric = ErrorMetric::lightmap;
  uint64_t dropped_samples = 0;
  std::string color_space;
  const plan::LightmapPlan* plan = nullptr;
  std::vector<LightmapReportEntry> lightmaps;
  size_t tracer_triangles = 0;         // traced, in world space
  size_t tracer_stored_triangles = 0;  // held: an instanced mesh's once (scene::Tracer::stored_triangle_count)
  size_t tracer_instances = 0;         // traced as Embree instances of a shared mesh
  size_t tracer_bytes = 0;
  std::vector<StageTime> stages;
  LeakScopeSummary leak_scope;    // which meshes could hide their own points, and the proximity test's size  // in the order they ran, each with its wall-clock seconds
  int64_t scene_problems = 0;               // all of them; result.skipped lists the ones that are listed
  const DenoiseOptions* denoise = nullptr;  // the denoiser's settings when NAME_irradiance_denoised.exr was asked for
  double denoise_seconds = 0;               // its guides and filter, over every lightmap
  const AtlasPack* atlas = nullptr;         // when the bake packed atlas pages: "atlas", its pages and regions
  uvgen::GenerateUvs generate_uvs = uvgen::GenerateUvs::automatic;
  const std::vector<GeneratedMeshUvs>* generated_uvs = nullptr;  // "generated_uvs": the meshes that got them
  const std::vector<volume::MediumInput>* media = nullptr;       // "media" (media_report.h) when the job has any
  const ProbeVolumeResult* probes = nullptr;                      // "probes" (probe_outputs.h) when it baked any
};

// The JSON text, ending in a newline.
std::string report_json(const LightmapBakeResult& result, const LightmapReport& report);

}  // namespace kiln::lightmap
