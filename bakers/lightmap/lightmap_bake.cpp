#include "bakers/lightmap/lightmap_bake.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <utility>

#include <tbb/parallel_for.h>

#include "bakers/bake/number_format.h"
#include "bakers/bake/range_check.h"
#include "bakers/bake/stop.h"
#include "bakers/image/color.h"
#include "bakers/image/texture_decode.h"
#include "bakers/lightmap/adaptive_sampler.h"
#include "bakers/lightmap/integrator.h"
#include "bakers/lightmap/leaks.h"
#include "bakers/lightmap/light_budget.h"
#include "bakers/lightmap/light_tracing.h"
#include "bakers/lightmap/lightmap_image.h"
#include "bakers/lightmap/lightmap_manifest.h"
#include "bakers/lightmap/lightmap_outputs.h"
#include "bakers/lightmap/lightmap_report.h"
#include "bakers/lightmap/lightmap_state.h"
#include "bakers/lightmap/memory.h"
#include "bakers/lightmap/texels.h"
#include "bakers/lightmap/tracer_query.h"
#include "bakers/plan/lightmap_plan.h"
#include "bakers/scene/light_sampler.h"
#include "bakers/scene/scene_check.h"
#include "bakers/scene/tracer.h"

namespace kiln::lightmap {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// One bake's state, filled stage by stage (bake_lightmaps lists the stages). Not moved once a stage has run: the
// tracer, the lights and the transport context refer to the checked scene and to each other.
struct LightmapBakeRun {
  LightmapBakeRun(const LightmapBakeInput& input, const bake::BakeControl& bake_control)
      : in(input),
        control(bake_control),
        stop(control.cancel, deadline(input, t0)),
        cancel_only(control.cancel, Clock::time_point::max()) {}

  static Clock::time_point deadline(const LightmapBakeInput& in, Clock::time_point t0) {
    if (!(in.time_limit_seconds > 0)) return Clock::time_point::max();
    return t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(in.time_limit_seconds));
  }

  const LightmapBakeInput& in;
  const bake::BakeControl& control;
  const Clock::time_point t0 = Clock::now();
  // The set-up stages stop at a cancel or the time limit; writing the outputs only at a cancel (the time limit ends
  // the sampling, whose result is then written).
  const bake::StopCheck stop, cancel_only;
  std::string stage = "scene";  // the set-up stage running, for the time limit's message
  double last_fraction = 0;     // the progress reported so far, which never decreases

  scene::CheckedScene checked;  // the scene as baked: textures and environment decoded, then cleaned
  std::optional<AtlasPack> atlas;  // when the input packs atlas pages
  std::string color_space;      // the working space every output is in
  plan::LightmapPlan plan;
  std::unique_ptr<scene::Tracer> tracer;
  std::unique_ptr<scene::SceneLights> lights;
  std::vector<ShadingMaterial> materials;
  TransportContext ctx;
  // Light tracing: the plan and context of the traced texels' own paths (direct light only), and the tracer.
  plan::LightmapPlan direct_plan;
  TransportContext direct_ctx;
  std::unique_ptr<LightTracer> light_tracer;
  std::vector<LightmapState> maps;
  uint64_t dropped = 0;  // estimates dropped over all passes
  LightmapBakeResult result;
  LightmapReport report;

  const scene::Scene& scene() const { return checked.scene; }

  void check_cancel() const {
    if (control.cancel && control.cancel->load()) throw bake::BakeCancelled();
  }

  void progress(double fraction, const std::string& stage, double error) {
    check_cancel();
    if (!control.progress) return;
    bake::BakeProgress p;
    last_fraction = std::max(last_fraction, std::clamp(fraction, 0.0, 1.0));
    p.fraction = last_fraction;
    p.samples = result.samples;
    p.error_estimate = error;
    p.stage = stage;
    control.progress(p);
  }
};

// ---- 1. The scene: textures and environment decoded, then checked and cleaned ----

// Runs a decoder of input bytes; what it throws about them (not a cancellation) becomes an InvalidInput naming
// `field`, with the decoder's message as the problem.
template <class Decode>
auto decode_field(const std::string& field, const Decode& decode) {
  try {
    return decode();
  } catch (const bake::BakeCancelled&) {
    throw;
  } catch (const std::runtime_error& e) {
    throw bake::InvalidInput(field, e.what());
  } catch (const std::invalid_argument& e) {
    throw bake::InvalidInput(field, e.what());
  }
}

void decode_textures(LightmapBakeRun& run, scene::Scene& scene) {
  for (size_t i = 0; i < run.in.textures.size(); ++i) {
    const EncodedTexture& t = run.in.textures[i];
    image::DecodedTexture d = decode_field("textures[" + std::to_string(i) + "]",
                                           [&] { return image::decode_texture(t.bytes, t.color_space, t.name); });
    if (d.replaced + d.clamped > 0) {
      run.result.skipped.push_back("texture " + t.name + ": " + std::to_string(d.replaced) +
                                   " texels not usable as a reflectance (NaN, infinite or negative) set to 0, " +
                                   std::to_string(d.clamped) + " above 1 clamped to 1");
    }
    scene.textures.push_back({t.name, d.width, d.height, std::move(d.texels)});
  }
}

void decode_environment(LightmapBakeRun& run, scene::Scene& scene) {
  if (run.in.environment_image.empty()) return;
  const envmap::EnvironmentInput env = decode_field("environment_image", [&] {
    return envmap::decode_environment(run.in.environment_image, run.in.environment_decode);
  });
  scene.environment = scene::Environment{};
  scene.environment.width = env.image.width;
  scene.environment.height = env.image.height;
  scene.environment.equirect = env.image.pixels;
  scene.environment.rotation_degrees = env.rotation_degrees;
  if (env.sanitized.total() > 0) {
    run.result.skipped.push_back("environment: " + std::to_string(env.sanitized.total()) +
                                 " texels not usable as radiance (NaN, infinite or negative) replaced by the "
                                 "documented rule of bakers/envmap/env_input.h");
  }
}

void prepare_scene(LightmapBakeRun& run) {
  scene::Scene input = run.in.scene;
  decode_textures(run, input);
  run.color_space = image::ColorConfig::active().working_space();
  run.stop.check();
  decode_environment(run, input);
  run.stop.check();
  if (run.in.atlas.texel_density > 0) {
    AtlasOptions options = run.in.atlas;
    options.padding = run.in.padding;
    run.checked = check_and_pack_scene(std::move(input), options, run.stop, run.atlas.emplace());
  } else {
    run.checked = scene::check_scene(input);
  }
  run.stop.check();
  for (const scene::Problem& p : run.checked.report.problems) {
    run.result.skipped.push_back(std::string(scene::to_string(p.kind)) + ": " + p.what + "; " + p.action);
  }
  run.progress(0.01, "scene", -1);
}

// ---- 2. The plan ----

void plan_bake(LightmapBakeRun& run) {
  plan::LightmapPlanOptions options;
  options.target_error = run.in.target_error;
  options.max_bounces = run.in.max_bounces;
  options.force_effects = run.in.force_effects;
  options.directional = run.in.directional;
  options.per_texel_error = run.in.error_metric == ErrorMetric::texel;
  run.plan = run.in.full_simulation ? plan::full_plan(run.scene(), options) : plan::plan_lightmap(run.scene(), options);
  run.result.plan = run.plan.decisions;
}

// ---- 3. Tracer, lights, materials ----

void prepare_transport(LightmapBakeRun& run) {
  const scene::Scene& s = run.scene();
  const plan::LightmapPlan& plan = run.plan;
  run.stage = "tracer";
  scene::TracerOptions tracer_options;
  tracer_options.stop = &run.stop;
  run.tracer = std::make_unique<scene::Tracer>(s, tracer_options);
  run.stage = "lights";
  scene::LightSamplingOptions light_options;
  light_options.point_lights = plan.point_lights;
  light_options.spot_lights = plan.spot_lights;
  light_options.directional_lights = plan.directional_lights;
  light_options.area_lights = plan.area_lights;
  light_options.emissive_triangles = plan.emissive_triangles;
  light_options.environment = plan.environment_sampling;
  light_options.environment_importance_map = plan.environment_importance_map;
  run.lights = std::make_unique<scene::SceneLights>(s, light_options);
  run.materials = shading_materials(s, plan);
  TransportContext& ctx = run.ctx;
  ctx.scene = &s;
  ctx.tracer = run.tracer.get();
  ctx.lights = run.lights.get();
  ctx.plan = &run.plan;
  ctx.materials = &run.materials;
  ctx.ray_log = run.in.ray_log;
  ctx.directional = run.in.directional;
  prepare_context(ctx);
  if (run.in.ao) {
    // AO within a tenth of the scene's size: the usual contact-shadow scale, and independent of the scene's unit.
    ctx.ao_distance = 0.1 * scene::scene_bounding_radius(s);
  }
  run.progress(0.03, "tracer", -1);
}

// ---- 4. Texels of every lightmap, leaks resolved ----

void rasterize_texels(LightmapBakeRun& run) {
  const LightmapBakeInput& in = run.in;
  const TracerRayQuery query(*run.tracer, run.scene(), in.ray_log);
  // Triangles the scene check keeps for tracing but not for baking (UVs outside [0, 1], zero UV area).
  std::vector<std::vector<uint8_t>> bake_mask;
  for (const auto& t : run.checked.triangles) bake_mask.push_back(t.bake);
  for (const std::string& name : lightmap_names(run.scene())) {
    const auto it = in.resolutions.find(run.checked.input_lightmap_name(name));
    RasterOptions raster;
    raster.width = raster.height = run.atlas                           ? in.atlas.page_size
                                   : it != in.resolutions.end() ? it->second
                                                                : in.resolution;
    raster.bake_mask = &bake_mask;
    run.stage = "rasterization of lightmap '" + name + "'";
    LightmapTexels texels = rasterize_lightmap(run.scene(), name, raster, run.stop);
    run.stage = "leak probes of lightmap '" + name + "'";
    const LeakReport leaks = fix_leaks(texels, query, LeakOptions{}, run.stop);
    run.result.rays += leaks.rays;
    run.result.probe_rays += leaks.rays;
    run.maps.push_back(make_lightmap_state(name, std::move(texels), leaks, in.ao, in.directional));
    run.check_cancel();
  }
  if (run.maps.empty()) {
    throw bake::InvalidInput("",
                             "nothing to bake: no instance has a lightmap (meshes need lightmap UVs, TEXCOORD_1 "
                             "or TEXCOORD_0, and instances with bake set); " +
                                 run.checked.report.summary());
  }
  run.progress(0.05, "texels", -1);
}

// ---- 5. Adaptive passes (adaptive_sampler.h) ----

SamplingOptions sampling_options(const LightmapBakeRun& run) {
  SamplingOptions o;
  o.target_error = run.in.target_error;
  o.metric = run.in.error_metric;
  o.min_samples = run.in.min_samples;
  o.max_samples = run.in.max_samples;
  o.seed = run.in.seed;
  o.directional = run.in.directional;
  if (run.in.time_limit_seconds > 0) {
    o.deadline =
        run.t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(run.in.time_limit_seconds));
  }
  return o;
}

// After a pass: the error over every valid texel of every lightmap, a point of the curve and the progress.
void record_pass(LightmapBakeRun& run, uint64_t pass) {
  std::vector<LightmapImage::ErrorSummary> summaries(run.maps.size());
  tbb::parallel_for(size_t{0}, run.maps.size(), [&](size_t mi) {
    summaries[mi] = run.maps[mi].image.error_summary(run.in.target_error, 0, run.in.error_metric);
  });
  double sum_sq = 0;
  size_t estimated = 0, above = 0, valid = 0;
  for (const LightmapImage::ErrorSummary& e : summaries) {
    sum_sq += e.rms * e.rms * static_cast<double>(e.estimated);
    estimated += e.estimated;
    above += e.above_target;
    valid += e.valid;
  }
  const double rms = estimated ? std::sqrt(sum_sq / static_cast<double>(estimated)) : -1;
  run.result.curve.push_back({seconds_since(run.t0), run.result.samples, rms});
  const double done = valid ? 1.0 - static_cast<double>(above) / static_cast<double>(valid) : 1.0;
  run.progress(0.05 + 0.9 * done, "pass " + std::to_string(pass + 1), rms);
}

// ---- 5a. Light tracing (light_tracing.h) ----

// Marks the traced texels and builds the tracer; false when the plan has no light tracing or no light emits rays.
bool prepare_light_tracing(LightmapBakeRun& run) {
  if (!run.plan.light_tracing) return false;
  LightTracingStats stats;
  for (LightmapState& m : run.maps) {
    const size_t traced = mark_traced_texels(m);
    stats.texels_traced += traced;
    stats.texels_gathered += m.texels.valid_count() - traced;
  }
  run.light_tracer = std::make_unique<LightTracer>(run.ctx, run.maps, run.plan.bounces, run.in.seed);
  if (!run.light_tracer->active()) {
    for (LightmapState& m : run.maps) m.traced.clear();
    run.light_tracer.reset();
    return false;
  }
  stats.on = true;
  run.result.light_tracing = stats;
  run.direct_plan = run.plan;
  run.direct_plan.bounces = 0;
  run.direct_plan.russian_roulette = false;
  run.direct_ctx = run.ctx;
  run.direct_ctx.plan = &run.direct_plan;
  return true;
}

// Every traced texel's term from the rays so far.
void update_traced_terms(LightmapBakeRun& run) {
  for (size_t mi = 0; mi < run.maps.size(); ++mi) {
    LightmapState& m = run.maps[mi];
    m.image.enable_traced();
    tbb::parallel_for(size_t{0}, m.traced.size(), [&](size_t t) {
      if (m.traced[t])
        m.image.set_traced(t, run.light_tracer->irradiance(mi, t), run.light_tracer->replica_luminance(mi, t));
    });
  }
}

// Traced texels whose term falls short at the rays traced hand their indirect light back to their own paths
// (light_budget.h): their estimates so far (direct light only) are dropped and they gather all their light.
void gather_the_rest(LightmapBakeRun& run, const std::vector<TracedTexel>& texels, const SamplingOptions& o) {
  LightTracingStats& stats = run.result.light_tracing;
  const double rays = static_cast<double>(run.light_tracer->rays_traced());
  for (const TracedTexel& x : texels) {
    if (!gathers_instead(x, rays, o.target_error)) continue;
    LightmapState& m = run.maps[x.map];
    m.traced[x.texel] = 0;
    m.image.clear_traced(x.texel);
    m.image.reset(x.texel);
    m.attempts[x.texel] = 0;
    --stats.texels_traced;
    ++stats.texels_gathered;
  }
}

// Rays per estimate of the traced texels' direct light and of all of a texel's light, counted on a pass.
GatherCosts gather_costs(const PassCounts& c) {
  const auto per_estimate = [](uint64_t rays, uint64_t estimates) {
    return estimates ? static_cast<double>(rays) / static_cast<double>(estimates) : 0.0;
  };
  GatherCosts costs;
  costs.direct = per_estimate(c.traced_rays, c.traced_estimates);
  costs.full = per_estimate(c.rays - c.traced_rays, c.estimates - c.traced_estimates);
  // No texel gathered all its light in the pass: a full estimate traces about 3.4 times a direct one's rays (Cornell
  // box, 8 bounces: 22.6 and 6.9).
  if (!(costs.full > 0)) costs.full = 3.4 * costs.direct;
  return costs;
}

// Rays from the lights, in rounds that at most quadruple the total, up to the number that minimises the bake's time
// (light_budget.h), the time limit, or max_samples rays per traced texel. `costs`: of the texels' own estimates,
// counted on the first pass. Costs are counted in rays, not seconds, so that the bytes do not depend on the
// machine's speed or load.
void trace_light(LightmapBakeRun& run, const SamplingOptions& o, const GatherCosts& costs) {
  LightTracer& lt = *run.light_tracer;
  LightTracingStats& stats = run.result.light_tracing;
  const Clock::time_point t0 = Clock::now();
  const double texels = static_cast<double>(std::max<size_t>(1, stats.texels_traced));
  const double cap = texels * static_cast<double>(o.max_samples);
  double want = std::max(16 * texels, 65536.0) / kFirstReflections;
  std::vector<TracedTexel> traced;
  for (;;) {
    const double more = std::min(want, cap) - static_cast<double>(lt.rays_traced());
    if (!(more >= 1)) break;
    const LightTracingCounts c = lt.trace(static_cast<uint64_t>(std::ceil(more)), o.deadline, run.control.cancel);
    run.check_cancel();
    stats.rays += c.rays;
    stats.deposits += c.deposits;
    run.result.rays += c.rays;
    update_traced_terms(run);
    traced = traced_texels(run.maps, lt, o.metric);
    if (c.out_of_time) break;
    const double n = static_cast<double>(lt.rays_traced());
    const double cost_per_ray = kLightRayCost * static_cast<double>(stats.rays) / n;
    want = std::min(best_light_rays(traced, o.target_error, n, cost_per_ray, costs), 4 * n);
    if (!(want > n * 1.05)) break;
  }
  stats.light_rays = lt.rays_traced();
  gather_the_rest(run, traced, o);
  stats.seconds += seconds_since(t0);
}

void sample_adaptively(LightmapBakeRun& run) {
  const SamplingOptions options = sampling_options(run);
  LightmapBakeResult& result = run.result;
  const bool tracing = prepare_light_tracing(run);
  for (uint64_t pass = 0;; ++pass) {
    const std::vector<TexelBatch> batches = schedule_pass(run.maps, options);
    if (batches.empty()) break;
    const PassCounts counts =
        run_pass(run.maps, batches, run.ctx, options, run.control, tracing ? &run.direct_ctx : nullptr);
    run.check_cancel();
    // After the first pass the texels have a brightness to measure light tracing's error against.
    if (tracing && pass == 0) trace_light(run, options, gather_costs(counts));
    result.rays += counts.rays;
    result.occlusion_rays += counts.occlusion_rays;
    result.samples += counts.paths;
    result.general_vertices += counts.general_vertices;
    run.dropped += counts.dropped;
    record_pass(run, pass);
    if (counts.out_of_time || Clock::now() >= options.deadline) break;
  }
  result.error_estimate = result.curve.empty() ? 0 : std::max(0.0, result.curve.back().error);
}

// ---- 6. Outputs ----

// One lightmap's images, in a fixed order, and its entry in the report.
void write_lightmap(LightmapBakeRun& run, const LightmapState& m) {
  const LightmapBakeInput& in = run.in;
  std::vector<bake::BakeOutput>& outputs = run.result.outputs;
  LightmapOutputOptions options;
  options.padding = in.padding;
  options.color_space = run.color_space;
  options.metric = in.error_metric;
  options.stop = &run.cancel_only;
  for (bake::BakeOutput& o : encode_lightmap(m.image, options)) outputs.push_back(std::move(o));
  if (in.denoise) {
    const Clock::time_point t0 = Clock::now();
    outputs.push_back(
        denoised_output(m, run.scene(), in.denoise_options, in.padding, run.color_space, run.cancel_only));
    run.report.denoise_seconds += seconds_since(t0);
  }
  if (in.radiance) outputs.push_back(radiance_output(m, run.scene(), run.materials, run.color_space));
  if (in.ao) outputs.push_back(ao_output(m, run.ctx.ao_distance));
  std::optional<ShError> sh;
  if (in.directional) {
    sh = sh_error(m);
    outputs.push_back(sh_output(m, *sh, run.color_space));
  }
  if (in.preview) outputs.push_back(preview_output(m, in.padding, run.color_space, run.cancel_only));
  const std::string& input_name = run.checked.input_lightmap_name(m.name);
  run.report.lightmaps.push_back({m.name, input_name == m.name ? "" : input_name, m.image.width(),
                                  m.image.error_summary(in.target_error, 0, in.error_metric),
                                  sh, m.leaks, lightmap_memory(m.texels, lightmap_state_bytes(in.ao, in.directional, !m.traced.empty()))});
}

void write_report(LightmapBakeRun& run) {
  LightmapReport& report = run.report;
  report.target_error = run.in.target_error;
  report.error_metric = run.in.error_metric;
  report.dropped_samples = run.dropped;
  report.color_space = run.color_space;
  report.plan = &run.plan;
  report.tracer_triangles = run.tracer->triangle_count();
  report.tracer_bytes = run.tracer->memory_bytes();
  report.scene_problems = run.checked.report.total();
  report.denoise = run.in.denoise ? &run.in.denoise_options : nullptr;
  report.atlas = run.atlas ? &*run.atlas : nullptr;
  run.result.outputs.push_back({"report.json", "application/json", "", report_json(run.result, report)});
}

// lightmaps.json, and the atlas's part of report.json (written just before, so it is the last output).
void write_manifest(LightmapBakeRun& run) {
  ManifestInput m;
  m.input_scene = &run.in.scene;
  m.pack = &*run.atlas;
  m.texel_density = run.in.atlas.texel_density;
  for (const LightmapReportEntry& e : run.report.lightmaps) m.valid_texels[e.name] = e.error.valid;
  m.outputs = &run.result.outputs;
  run.result.outputs.push_back(manifest_output(m));
}

// The time limit ran out before the first sample: there is nothing to write, and the same job would run out again.
bake::InvalidInput out_of_time_in_set_up(const LightmapBakeRun& run) {
  return bake::InvalidInput(
      "time_limit_seconds",
      "the limit of " + bake::format_number(run.in.time_limit_seconds) + " s ran out during the set-up (" + run.stage +
          ", after " + bake::format_number(std::round(seconds_since(run.t0) * 100) / 100) +
          " s), before any texel was sampled; raise it, or lower the resolution or the scene's size");
}

void write_outputs(LightmapBakeRun& run) {
  for (const LightmapState& m : run.maps) {
    run.cancel_only.check();
    write_lightmap(run, m);
  }
  run.result.seconds = seconds_since(run.t0);
  write_report(run);
  if (run.atlas) write_manifest(run);
  run.progress(1.0, "done", run.result.error_estimate);
}

}  // namespace

std::optional<bake::InvalidInput> validate(const LightmapBakeInput& in) {
  using bake::check_range;
  using bake::InvalidInput;
  if (auto e = check_range("resolution", in.resolution, bounds::kLightmapResolution.real())) return e;
  for (const auto& [name, r] : in.resolutions) {
    if (auto e = check_range("resolutions[" + name + "]", r, bounds::kLightmapResolution.real())) return e;
  }
  if (auto e = check_range("padding", in.padding, bounds::kLightmapPadding.real())) return e;
  if (auto e = check_range("target_error", in.target_error, bounds::kLightmapTargetError)) return e;
  if (auto e = check_range("max_samples", static_cast<double>(in.max_samples), bounds::kLightmapSamples.real())) {
    return e;
  }
  const bounds::Range min_samples{1, static_cast<double>(in.max_samples)};
  if (auto e = check_range("min_samples", static_cast<double>(in.min_samples), min_samples)) return e;
  // 0 is "no limit" here; the protocol leaves the field unset for that.
  const bounds::Range time_limit{0, bounds::kLightmapTimeLimitSeconds.hi};
  if (auto e = check_range("time_limit_seconds", in.time_limit_seconds, time_limit)) return e;
  if (auto e = check_range("max_bounces", in.max_bounces, bounds::kMaxBounces.real())) return e;
  if (in.atlas.texel_density != 0) {
    if (auto e = check_atlas_options(in.atlas)) return e->under("atlas");
  }
  if (!in.textures.empty() && !in.scene.textures.empty()) {
    return InvalidInput("textures", "give textures either decoded in the scene or encoded, not both");
  }
  if (auto e = plan::check_forced_names(in.force_effects, plan::lightmap_effect_names())) return e;
  if (in.full_simulation && !in.force_effects.empty()) {
    return InvalidInput("force_effects", "a full simulation simulates everything; leave force_effects empty");
  }
  return std::nullopt;
}

LightmapBakeResult bake_lightmaps(const LightmapBakeInput& in, const bake::BakeControl& control) {
  if (auto problem = validate(in)) throw *problem;
  LightmapBakeRun run(in, control);
  try {
    prepare_scene(run);
    plan_bake(run);
    prepare_transport(run);
    rasterize_texels(run);
  } catch (const bake::OutOfTime&) {
    throw out_of_time_in_set_up(run);
  }
  sample_adaptively(run);
  write_outputs(run);
  return std::move(run.result);
}

}  // namespace kiln::lightmap
