#include "bakers/lightmap/lightmap_report.h"

#include <algorithm>
#include <string>

#include <nlohmann/json.hpp>

#include "bakers/bake/number_format.h"
#include "bakers/lightmap/lightmap_manifest.h"
#include "bakers/lightmap/media_report.h"
#include "bakers/lightmap/probe_outputs.h"

namespace kiln::lightmap {
namespace {

using Json = nlohmann::ordered_json;

Json plan_json(const std::vector<plan::Decision>& decisions) {
  Json plan = Json::array();
  for (const plan::Decision& d : decisions) {
    plan.push_back({{"effect", d.effect}, {"enabled", d.enabled}, {"forced", d.forced}, {"reason", d.reason}});
  }
  return plan;
}

Json curve_json(const std::vector<ErrorPoint>& curve) {
  Json points = Json::array();
  for (const ErrorPoint& p : curve) {
    points.push_back({{"seconds", p.seconds}, {"samples", p.samples}, {"error", p.error}});
  }
  return points;
}

Json lightmap_json(const LightmapReportEntry& m) {
  Json j;
  j["name"] = m.name;
  if (!m.input_name.empty()) j["input_name"] = m.input_name;
  j["resolution"] = m.resolution;
  j["valid_texels"] = m.error.valid;
  j["samples_per_texel_point"] = m.memory.samples_per_valid_texel;
  j["brightness"] = m.error.brightness;
  j["error_rms"] = m.error.rms;
  j["error_max"] = m.error.max;
  j["above_target"] = m.error.above_target;
  if (m.sh) {
    j["sh_error_rms"] = m.sh->rms;
    j["sh_error_max"] = m.sh->max;
  }
  j["leaks"] = {{"probed", m.leaks.samples - m.leaks.pruned},
                {"pruned", m.leaks.pruned},
                {"moved", m.leaks.moved},
                {"invalidated", m.leaks.invalidated},
                {"texels_invalidated", m.leaks.texels_invalidated}};
  j["memory_bytes"] = m.memory.total_bytes;
  j["memory"] = m.memory.describe();
  if (m.seams) {
    const SeamReport& s = *m.seams;
    // Mismatches: |bilinear lookup on one side − on the other| over the lightmap's brightness (seams.h).
    j["seams"] = {{"stitched", true},
                  {"edges", s.seams},
                  {"non_manifold_edges", s.non_manifold},
                  {"left_out", s.left_out},
                  {"over_memory_budget", s.over_budget},
                  {"lookup_pairs", s.samples},
                  {"texels_changed", s.texels_changed},
                  {"values_held_at_zero", s.held_at_zero},
                  {"mismatch_max_before", s.mismatch_before},
                  {"mismatch_max_after", s.mismatch_after},
                  {"mismatch_rms_before", s.rms_before},
                  {"mismatch_rms_after", s.rms_after},
                  {"components", s.components},
                  {"factored_components", s.factored},
                  {"peak_bytes", s.peak_bytes},
                  {"iterations", s.iterations},
                  {"converged", s.converged},
                  {"seconds", s.seconds}};
  } else {
    j["seams"] = {{"stitched", false}};
  }
  return j;
}

Json tracer_json(const LightmapReport& report) {
  const double per_triangle =
      report.tracer_triangles ? static_cast<double>(report.tracer_bytes) / report.tracer_triangles : 0.0;
  return {{"triangles", report.tracer_triangles},
          {"stored_triangles", report.tracer_stored_triangles},
          {"instanced_instances", report.tracer_instances},
          {"memory_bytes", report.tracer_bytes},
          {"bytes_per_triangle", per_triangle}};
}

// Each stage's seconds and share of the bake's.
Json stages_json(const std::vector<StageTime>& stages, double total) {
  Json out = Json::array();
  for (const StageTime& s : stages) {
    out.push_back({{"stage", s.name}, {"seconds", s.seconds}, {"fraction", total > 0 ? s.seconds / total : 0.0}});
  }
  return out;
}

Json denoise_json(const LightmapReport& report) {
  if (!report.denoise) return {{"denoised", false}};
  const DenoiseOptions& o = *report.denoise;
  return {{"denoised", true},
          {"filter", describe(o)},
          {"levels", o.levels},
          {"sigma_luminance", o.sigma_luminance},
          {"sigma_normal", o.sigma_normal},
          {"sigma_position", o.sigma_position},
          {"seconds", report.denoise_seconds}};
}

Json light_tracing_json(const LightTracingStats& s) {
  if (!s.on) return {{"on", false}};
  return {{"on", true},
          {"light_rays", s.light_rays},
          {"rays", s.rays},
          {"deposits", s.deposits},
          {"texels_traced", s.texels_traced},
          {"texels_gathered", s.texels_gathered},
          {"seconds", s.seconds}};
}

Json memory_json(const LightmapBakeResult::Memory& m) {
  return {{"limit_bytes", m.limit_bytes},
          {"estimate_bytes", m.estimate_bytes},
          {"tiled", m.tile_size > 0},
          {"tile_size", m.tile_size},
          {"tiles", m.tiles},
          {"tiles_unsampled", m.tiles_unsampled},
          {"held_peak_bytes", m.held_peak_bytes},
          {"bytes_per_texel_held", m.bytes_per_texel_held}};
}

Json time_budget_json(const LightmapBakeResult::TimeBudget& b) {
  if (!b.on) return {{"on", false}};
  Json j{{"on", true},
         {"sampled_seconds_per_texel", b.sampled_rate},
         {"first_pass_seconds_per_texel", b.first_pass_rate},
         {"unsampled_seconds_per_texel", b.unsampled_rate},
         {"output_seconds_per_page_texel", b.output_rate}};
  if (b.sampling_ended_seconds < 0) {
    j["sampling_ended_seconds"] = nullptr;
  } else {
    j["sampling_ended_seconds"] = b.sampling_ended_seconds;
    j["forecast_after_seconds"] = b.forecast_seconds;
    j["after_seconds"] = b.after_seconds;
  }
  return j;
}

std::string unknown_error_reason(const LightmapBakeResult& result) {
  if (result.samples > 0) return "no texel has two estimates to measure its error from";
  const LightmapBakeResult::TimeBudget& b = result.time_budget;
  if (b.on && b.sampling_ended_seconds >= 0) {
    return "no texel was sampled: the time limit left no time for it beside what no limit can skip, rasterizing the "
           "tiles and writing the pages (forecast " +
           bake::format_number(b.forecast_seconds) + " s, took " + bake::format_number(b.after_seconds) +
           " s); raise the time limit or lower the texel density";
  }
  return "no texel was sampled (the time limit ran out before the first sample)";
}

}  // namespace

std::string report_json(const LightmapBakeResult& result, const LightmapReport& report) {
  Json j;
  j["baker"] = kLightmapBakerVersion;
  j["seconds"] = result.seconds;
  j["samples"] = result.samples;
  j["rays"] = result.rays;
  j["occlusion_rays"] = result.occlusion_rays;
  j["general_bsdf_vertices"] = result.general_vertices;
  j["mrays_per_second"] = result.rays / std::max(result.seconds, 1e-9) / 1e6;
  j["target_error"] = report.target_error;
  j["error_metric"] = to_string(report.error_metric);
  if (result.error_estimate >= 0) {
    j["error_estimate"] = result.error_estimate;
  } else {
    j["error_estimate"] = nullptr;
    j["error_estimate_unknown"] = unknown_error_reason(result);
  }
  j["dropped_samples"] = report.dropped_samples;
  j["color_space"] = report.color_space;
  j["units"] = "irradiance W/m^2";
  j["plan"] = plan_json(report.plan->decisions);
  j["bounces"] = report.plan->bounces;
  j["albedo_max"] = report.plan->albedo_max;
  j["stages"] = stages_json(report.stages, result.seconds);
  j["curve"] = curve_json(result.curve);
  j["lightmaps"] = Json::array();
  for (const LightmapReportEntry& m : report.lightmaps) j["lightmaps"].push_back(lightmap_json(m));
  j["light_tracing"] = light_tracing_json(result.light_tracing);
  j["denoise"] = denoise_json(report);
  j["tracer"] = tracer_json(report);
  j["memory"] = memory_json(result.memory);
  j["time_budget"] = time_budget_json(result.time_budget);
  const LeakScopeSummary& ls = report.leak_scope;
  j["leak_scope"] = {{"convex_meshes", ls.convex_meshes},
                     {"height_field_meshes", ls.height_field_meshes},
                     {"star_shaped_meshes", ls.star_shaped_meshes},
                     {"valley_triangles", ls.valley_triangles},
                     {"probed_meshes", ls.probed_meshes},
                     {"chunks", ls.chunks},
                     {"rule",
                      "probed only near other instances (a texel of their chunks' boxes) or on meshes that "
                      "can hide their own points (neither convex, nor a height field, nor closed and star-shaped; and "
                      "the triangles of "
                      "sharp valleys of the last)"}};
  j["scene_problems"] = {{"total", report.scene_problems}, {"listed", result.skipped}};
  if (report.atlas) {
    std::map<std::string, size_t> valid;
    for (const LightmapReportEntry& m : report.lightmaps) valid[m.name] = m.error.valid;
    j["atlas"] = Json::parse(atlas_report_json(*report.atlas, valid));
  }
  if (report.generated_uvs) {
    j["generated_uvs"] = Json::parse(generated_uvs_json(report.generate_uvs, *report.generated_uvs));
  }
  if (report.media && !report.media->empty()) j["media"] = Json::parse(media_report_json(*report.plan, *report.media));
  if (report.probes) j["probes"] = Json::parse(probe_report_json(*report.probes));
  // Names come from the scene: bytes that are not UTF-8 are replaced rather than failing the bake.
  return j.dump(2, ' ', false, Json::error_handler_t::replace) + "\n";
}

}  // namespace kiln::lightmap
