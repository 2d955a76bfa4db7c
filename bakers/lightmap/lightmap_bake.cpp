#include "bakers/lightmap/lightmap_bake.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <memory>
#include <optional>
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
#include "bakers/lightmap/leak_scope.h"
#include "bakers/lightmap/leaks.h"
#include "bakers/lightmap/light_budget.h"
#include "bakers/lightmap/light_tracing.h"
#include "bakers/lightmap/lightmap_image.h"
#include "bakers/lightmap/lightmap_manifest.h"
#include "bakers/lightmap/lightmap_outputs.h"
#include "bakers/lightmap/lightmap_report.h"
#include "bakers/lightmap/lightmap_results.h"
#include "bakers/lightmap/lightmap_state.h"
#include "bakers/lightmap/lightmap_uvgen.h"
#include "bakers/lightmap/memory.h"
#include "bakers/lightmap/memory_estimate.h"
#include "bakers/lightmap/probe_outputs.h"
#include "bakers/lightmap/seams.h"
#include "bakers/lightmap/stage_timer.h"
#include "bakers/lightmap/texel_guides.h"
#include "bakers/lightmap/texels.h"
#include "bakers/lightmap/tile_time_budget.h"
#include "bakers/lightmap/tracer_query.h"
#include "bakers/plan/lightmap_plan.h"
#include "bakers/scene/light_sampler.h"
#include "bakers/scene/scene_check.h"
#include "bakers/scene/tracer.h"
#include "bakers/volume/medium_sum.h"

namespace kiln::lightmap {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

Clock::time_point time_after(Clock::time_point t0, double seconds) {
  return t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
}

// One bake's state, filled stage by stage (bake_lightmaps lists the stages). Not moved once a stage has run: the
// tracer, the lights and the transport context refer to the checked scene and to each other.
struct LightmapBakeRun {
  LightmapBakeRun(const LightmapBakeInput& input, const bake::BakeControl& bake_control)
      : in(input),
        control(bake_control),
        stop(control.cancel, time_limit_at),
        cancel_only(control.cancel, Clock::time_point::max()) {}

  static Clock::time_point deadline(const LightmapBakeInput& in, Clock::time_point t0) {
    if (!(in.time_limit_seconds > 0)) return Clock::time_point::max();
    return time_after(t0, in.time_limit_seconds);
  }

  const LightmapBakeInput& in;
  const bake::BakeControl& control;
  const Clock::time_point t0 = Clock::now();
  const Clock::time_point time_limit_at = deadline(in, t0);  // max() when the bake has no time limit
  // The set-up stages stop at a cancel or the time limit; writing the outputs only at a cancel (the time limit ends
  // the sampling, whose result is then written).
  const bake::StopCheck stop, cancel_only;
  std::string stage = "scene";  // the set-up stage running, for the time limit's message
  double last_fraction = 0;     // the progress reported so far, which never decreases

  scene::CheckedScene checked;                    // the scene as baked: textures and environment decoded, then cleaned
  std::optional<AtlasPack> atlas;                 // when the input packs atlas pages
  std::vector<GeneratedMeshUvs> generated_uvs;    // the meshes that got generated lightmap UVs
  std::vector<std::string> output_names;          // of every output handed over so far, in order
  std::string color_space;                        // the working space every output is in
  std::vector<volume::MediumInput> media_inputs;  // the input's, fog given the scene's box
  std::vector<std::unique_ptr<volume::Medium>> media;  // those, built (their grids checked) before the plan
  std::unique_ptr<volume::MediumSum> medium_sum;       // when several media are simulated: what paths track
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
  std::optional<ProbeVolumeResult> probes;  // when the input asks for probes, once baked
  LightmapMemoryEstimate memory;            // as planned: untiled, or the tile size (memory.tile_size)
  uint64_t dropped = 0;                     // estimates dropped over all passes
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
  // Within the "scene" stage's time; report.json's generated_uvs gives each mesh's seconds.
  run.stage = "lightmap UV generation";
  run.generated_uvs = generate_scene_uvs(input, run.in, run.stop);
  run.stage = "scene";
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

// ---- 2. Memory: whole pages, or tiles (memory_estimate.h) ----

// The texels on a side of lightmap `name` (a file stem of the checked scene, whose settings the job gives under its
// input name), or of an atlas page.
int lightmap_resolution(const LightmapBakeRun& run, const std::string& name) {
  if (run.atlas) {
    for (const AtlasPage& page : run.atlas->pages)
      if (page.name == name) return page.size;
    return run.in.atlas.page_size;
  }
  const auto it = run.in.resolutions.find(run.checked.input_lightmap_name(name));
  return it != run.in.resolutions.end() ? it->second : run.in.resolution;
}

}  // namespace

LightmapJobSize output_size(const LightmapBakeInput& in, bool streamed) {
  LightmapJobSize size;
  size.ao = in.ao;
  size.directional = in.directional;
  size.radiance = in.radiance;
  size.denoise = in.denoise;
  size.preview = in.preview;
  size.seams = in.stitch_seams;
  size.streamed = streamed;
  size.probes = in.probes.enabled() ? in.probes.max_probes : 0;
  return size;
}

namespace {

// What the estimate needs to know of the bake, from its input and the checked scene: the same model the daemon
// applies to the spec (daemon/translate_lightmap.cpp), with the meshes' sizes as their blobs would have them.
LightmapJobSize job_size(const LightmapBakeRun& run) {
  const LightmapBakeInput& in = run.in;
  const scene::Scene& s = run.scene();
  LightmapJobSize size = output_size(in, static_cast<bool>(run.control.output_sink));
  for (const std::string& name : in.lightmaps ? lightmap_names(s) : std::vector<std::string>{}) {
    const auto side = static_cast<uint64_t>(lightmap_resolution(run, name));
    size.lightmap_texels.push_back(side * side);
  }
  std::vector<uint64_t> mesh_triangles;
  for (const scene::Mesh& m : s.meshes) mesh_triangles.push_back(m.indices.size() / 3);
  count_triangles(mesh_triangles, s.instances, size);
  // KILNMSH1 (daemon/mesh_blob_decode.h): float positions, normals and UVs, 12 bytes of indices a triangle.
  for (const scene::Mesh& m : s.meshes) {
    size.mesh_blob_bytes += 20 + 12 * (m.positions.size() + m.normals.size()) +
                            8 * (m.uv.size() + m.lightmap_uv.size()) + 4 * m.indices.size();
  }
  for (const EncodedTexture& t : in.textures) size.texture_blob_bytes += t.bytes.size();
  size.environment_blob_bytes = in.environment_image.size();
  return size;
}

void plan_memory(LightmapBakeRun& run) {
  const LightmapJobSize size = job_size(run);
  run.memory =
      run.in.tile_size > 0 ? estimate_memory(size, run.in.tile_size) : plan_memory(size, run.in.memory_limit_bytes);
  LightmapBakeResult::Memory& m = run.result.memory;
  m.limit_bytes = run.in.memory_limit_bytes;
  m.estimate_bytes = run.memory.total;
  m.tile_size = run.memory.tile_size;
  m.bytes_per_texel_held = run.memory.bytes_per_texel_in_flight;
}

// ---- 2b. The plan ----

// The input's media, built; fog (a homogeneous medium without a box) fills the scene's box: beyond the scene it would
// take all light from infinitely far (the sun, the sky) on its infinitely long way in.
void build_media(LightmapBakeRun& run) {
  std::vector<volume::MediumInput>& inputs = run.media_inputs;
  inputs = run.in.media;  // grids are shared handles: no voxel is copied
  volume::Bounds3 box;
  const bool bounded = scene::scene_box(run.scene(), box.lo, box.hi);
  for (volume::MediumInput& m : inputs) {
    auto* fog = std::get_if<volume::HomogeneousMediumSpec>(&m.spec);
    if (fog && !fog->box && bounded) fog->box = box;
  }
  run.media = volume::make_media(inputs);
}

void plan_bake(LightmapBakeRun& run) {
  build_media(run);
  plan::LightmapPlanOptions options;
  options.target_error = run.in.target_error;
  options.max_bounces = run.in.max_bounces;
  options.force_effects = run.in.force_effects;
  options.directional = run.in.directional;
  options.per_texel_error = run.in.error_metric == ErrorMetric::texel;
  options.tiled = run.memory.tile_size > 0;
  options.media_inputs = &run.media_inputs;
  for (const auto& m : run.media) options.media.push_back(m.get());
  run.plan = run.in.full_simulation ? plan::full_plan(run.scene(), options) : plan::plan_lightmap(run.scene(), options);
  run.result.plan = run.plan.decisions;
}

// ---- 3. Tracer, lights, materials ----

// The media the plan simulates; paths track the one medium itself (its majorant grid skips empty space), or their
// sum.
void set_media(LightmapBakeRun& run, TransportContext& ctx) {
  for (int i : run.plan.media) ctx.media.push_back(run.media[i].get());
  ctx.media_scattering = run.plan.media_mode == plan::MediaMode::scattering;
  if (ctx.media.size() > 1) run.medium_sum = std::make_unique<volume::MediumSum>(ctx.media);
  ctx.medium = run.medium_sum ? run.medium_sum.get() : ctx.media.empty() ? nullptr : ctx.media[0];
}

void prepare_transport(LightmapBakeRun& run) {
  const scene::Scene& s = run.scene();
  const plan::LightmapPlan& plan = run.plan;
  run.stage = "tracer";
  scene::TracerOptions tracer_options;
  tracer_options.stop = &run.stop;
  {
    const StageTimer timer(run.report.stages, "tracer");
    run.tracer = std::make_unique<scene::Tracer>(s, tracer_options);
  }
  run.stage = "lights";
  const StageTimer timer(run.report.stages, "lights");
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
  set_media(run, ctx);
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
  std::optional<StageTimer> timer(std::in_place, run.report.stages, "leak_scope");
  run.stage = "leak scope";
  const LeakScope scope(run.scene(), LeakScopeOptions{}, run.stop);
  run.report.leak_scope = scope.summary();
  timer.reset();
  // Triangles the scene check keeps for tracing but not for baking (UVs outside [0, 1], zero UV area).
  std::vector<std::vector<uint8_t>> bake_mask;
  for (const auto& t : run.checked.triangles) bake_mask.push_back(t.bake);
  for (const std::string& name : lightmap_names(run.scene())) {
    RasterOptions raster;
    raster.width = raster.height = lightmap_resolution(run, name);
    raster.bake_mask = &bake_mask;
    run.stage = "rasterization of lightmap '" + name + "'";
    timer.emplace(run.report.stages, "rasterization");
    LightmapTexels texels = rasterize_lightmap(run.scene(), name, raster, run.stop);
    match_tracer_offsets(texels, *run.tracer);
    run.stage = "leak probes of lightmap '" + name + "'";
    timer.emplace(run.report.stages, "leak_probes");
    const std::vector<uint8_t> probe = scope.probe_mask(texels.samples, run.stop);
    const LeakReport leaks = fix_leaks(texels, query, LeakOptions{}, run.stop, &probe);
    timer.reset();
    run.result.rays += leaks.rays;
    run.result.probe_rays += leaks.rays;
    run.maps.push_back(make_lightmap_state(name, std::move(texels), leaks, in.ao, in.directional));
    run.maps.back().page = static_cast<uint32_t>(run.maps.size() - 1);
    run.check_cancel();
  }
  if (run.maps.empty()) {
    throw bake::InvalidInput("",
                             "nothing to bake: no instance has a lightmap (meshes need lightmap UVs, TEXCOORD_1 "
                             "or TEXCOORD_0, or generate_uvs other than never, and instances with bake set); " +
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
  o.deadline = run.time_limit_at;
  return o;
}

// The error over every valid texel of `maps`: RMS over those with an estimate, how many those are, how many are
// still above the target, of how many valid.
struct ErrorTotals {
  double sum_sq = 0;
  size_t estimated = 0, above = 0, valid = 0;

  void add(const LightmapImage::ErrorSummary& e) {
    sum_sq += e.rms * e.rms * static_cast<double>(e.estimated);
    estimated += e.estimated;
    above += e.above_target;
    valid += e.valid;
  }
  void add(const ErrorTotals& o) {
    sum_sq += o.sum_sq;
    estimated += o.estimated;
    above += o.above;
    valid += o.valid;
  }
  double rms() const { return estimated ? std::sqrt(sum_sq / static_cast<double>(estimated)) : -1; }
  double done() const { return valid ? 1.0 - static_cast<double>(above) / static_cast<double>(valid) : 1.0; }
};

ErrorTotals error_totals(const LightmapBakeRun& run, const std::vector<LightmapState>& maps) {
  std::vector<LightmapImage::ErrorSummary> summaries(maps.size());
  tbb::parallel_for(size_t{0}, maps.size(), [&](size_t mi) {
    summaries[mi] = maps[mi].image.error_summary(run.in.target_error, 0, run.in.error_metric);
  });
  ErrorTotals totals;
  for (const LightmapImage::ErrorSummary& e : summaries) totals.add(e);
  return totals;
}

// After a pass: the error over every valid texel of every lightmap, a point of the curve and the progress.
void record_pass(LightmapBakeRun& run, uint64_t pass) {
  const ErrorTotals totals = error_totals(run, run.maps);
  const double rms = totals.rms();
  run.result.curve.push_back({seconds_since(run.t0), run.result.samples, rms});
  run.progress(0.05 + 0.9 * totals.done(), "pass " + std::to_string(pass + 1), rms);
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

// Passes over `maps` until every texel is done or the options' deadline; `after_pass` follows each. Light tracing
// (when `tracing`) after the first pass.
void run_passes(LightmapBakeRun& run, std::vector<LightmapState>& maps, const SamplingOptions& options, bool tracing,
                const std::function<void(uint64_t)>& after_pass) {
  LightmapBakeResult& result = run.result;
  for (uint64_t pass = 0;; ++pass) {
    const std::vector<TexelBatch> batches = schedule_pass(maps, options);
    if (batches.empty()) break;
    const PassCounts counts =
        run_pass(maps, batches, run.ctx, options, run.control, tracing ? &run.direct_ctx : nullptr);
    run.check_cancel();
    // After the first pass the texels have a brightness to measure light tracing's error against.
    if (tracing && pass == 0) trace_light(run, options, gather_costs(counts));
    result.rays += counts.rays;
    result.occlusion_rays += counts.occlusion_rays;
    result.samples += counts.paths;
    result.general_vertices += counts.general_vertices;
    run.dropped += counts.dropped;
    after_pass(pass);
    if (counts.out_of_time || Clock::now() >= options.deadline) break;
  }
}

void sample_adaptively(LightmapBakeRun& run) {
  const SamplingOptions options = sampling_options(run);
  std::optional<StageTimer> timer(std::in_place, run.report.stages, "light_tracing_setup");
  const bool tracing = prepare_light_tracing(run);
  timer.emplace(run.report.stages, "passes");
  run_passes(run, run.maps, options, tracing, [&](uint64_t pass) { record_pass(run, pass); });
  LightmapBakeResult& result = run.result;
  // Unknown (−1) unless the last pass measured some texel's error: a bake the time limit ended before its first
  // sample has no error to report, and 0 would claim a perfect one.
  result.error_estimate = result.curve.empty() ? -1.0 : std::max(-1.0, result.curve.back().error);
}

// ---- 6. Outputs ----

// Hands an output to the caller's sink, or keeps it in the result when there is none (bake::BakeControl); either
// way its name joins `names` (lightmaps.json lists each page's files).
class OutputStream {
 public:
  OutputStream(const bake::BakeControl& control, std::vector<bake::BakeOutput>& kept, std::vector<std::string>& names)
      : sink_(control.output_sink), kept_(kept), names_(names) {}
  void push_back(bake::BakeOutput&& o) {
    names_.push_back(o.name);
    if (sink_) {
      sink_(std::move(o));
    } else {
      kept_.push_back(std::move(o));
    }
  }

 private:
  const std::function<void(bake::BakeOutput&&)>& sink_;
  std::vector<bake::BakeOutput>& kept_;
  std::vector<std::string>& names_;
};

// One lightmap's images, in a fixed order, and its entry in the report; each image leaves as soon as it is encoded.
// Returns the most bytes its seams' stitcher held at once (0 without stitching), held beside the results.
uint64_t write_lightmap(LightmapBakeRun& run, const LightmapResults& r, const LeakReport& leaks,
                        const LightmapMemory& memory) {
  const LightmapBakeInput& in = run.in;
  OutputStream outputs(run.control, run.result.outputs, run.output_names);
  LightmapOutputOptions options;
  options.padding = in.padding;
  options.color_space = run.color_space;
  options.metric = in.error_metric;
  options.stop = &run.cancel_only;
  std::optional<LightmapSeams> seams;
  if (in.stitch_seams) {
    seams.emplace(run.checked, r.name(), r.width(), r.height(), r.validity());
    options.finish = seams->finish(true);
  }
  const ImageFinish stitch = seams ? seams->finish(false) : ImageFinish{};
  for (bake::BakeOutput& o : encode_lightmap(r, options)) outputs.push_back(std::move(o));
  if (in.denoise) {
    const Clock::time_point t0 = Clock::now();
    outputs.push_back(denoised_output(r, in.denoise_options, in.padding, run.color_space, run.cancel_only, stitch));
    run.report.denoise_seconds += seconds_since(t0);
  }
  if (in.radiance) outputs.push_back(radiance_output(r, run.color_space, in.padding, run.cancel_only, stitch));
  if (in.ao) outputs.push_back(ao_output(r, run.ctx.ao_distance, in.padding, run.cancel_only, stitch));
  std::optional<ShError> sh;
  if (in.directional) {
    sh = sh_error(r);
    outputs.push_back(sh_output(r, *sh, run.color_space));
  }
  if (in.preview) outputs.push_back(preview_output(r, in.padding, run.color_space, run.cancel_only, stitch));
  const std::string& input_name = run.checked.input_lightmap_name(r.name());
  run.report.lightmaps.push_back({r.name(), input_name == r.name() ? "" : input_name, r.width(),
                                  r.error_summary(in.target_error, 0, in.error_metric), sh, leaks, memory,
                                  seams ? std::optional(seams->report()) : std::nullopt});
  return seams ? seams->report().peak_bytes : 0;
}

void write_report(LightmapBakeRun& run) {
  LightmapReport& report = run.report;
  report.target_error = run.in.target_error;
  report.error_metric = run.in.error_metric;
  report.dropped_samples = run.dropped;
  report.color_space = run.color_space;
  report.plan = &run.plan;
  report.media = &run.media_inputs;
  report.tracer_triangles = run.tracer->triangle_count();
  report.tracer_stored_triangles = run.tracer->stored_triangle_count();
  report.tracer_instances = run.tracer->instanced_instance_count();
  report.tracer_bytes = run.tracer->memory_bytes();
  report.scene_problems = run.checked.report.total();
  report.denoise = run.in.denoise ? &run.in.denoise_options : nullptr;
  report.atlas = run.atlas ? &*run.atlas : nullptr;
  report.generate_uvs = run.in.generate_uvs;
  report.generated_uvs = &run.generated_uvs;
  for (GeneratedMeshUvs& g : run.generated_uvs) {
    OutputStream(run.control, run.result.outputs, run.output_names).push_back(generated_uvs_output(g));
  }
  OutputStream(run.control, run.result.outputs, run.output_names)
      .push_back({"report.json", "application/json", "", report_json(run.result, report)});
}

// lightmaps.json, and the atlas's part of report.json (written just before, so it is the last output).
void write_manifest(LightmapBakeRun& run) {
  ManifestInput m;
  m.input_scene = &run.in.scene;
  m.pack = &*run.atlas;
  m.texel_density = run.in.atlas.texel_density;
  for (const LightmapReportEntry& e : run.report.lightmaps) m.valid_texels[e.name] = e.error.valid;
  m.output_names = &run.output_names;
  OutputStream(run.control, run.result.outputs, run.output_names).push_back(manifest_output(m));
}

// The time limit ran out before the first sample: there is nothing to write, and the same job would run out again.
bake::InvalidInput out_of_time_in_set_up(const LightmapBakeRun& run) {
  return bake::InvalidInput(
      "time_limit_seconds",
      "the limit of " + bake::format_number(run.in.time_limit_seconds) + " s ran out during the set-up (" + run.stage +
          ", after " + bake::format_number(std::round(seconds_since(run.t0) * 100) / 100) +
          " s), before any texel was sampled; raise it, or lower the resolution or the scene's size");
}

// ---- 7. Light probes (probe_volume.h), after the lightmaps or instead of them ----

// Places and samples the probes, hands their outputs over and keeps their result for the report. After lightmaps
// the time limit has had its share: placement then stops only at a cancel, and every probe still gets min_samples.
void bake_probes(LightmapBakeRun& run) {
  const LightmapBakeInput& in = run.in;
  const StageTimer timer(run.report.stages, "probes");
  run.stage = "probe placement";
  ProbeSamplingOptions o;
  o.stopping = sampling_options(run);
  o.cancel = run.control.cancel;
  const double start = in.lightmaps ? 0.95 : 0.05, span = in.lightmaps ? 0.04 : 0.9;
  o.progress = [&](double done, double error) { run.progress(start + span * done, "probes", error); };
  run.probes = bake_probe_volume(run.ctx, in.probes, o, in.lightmaps ? run.cancel_only : run.stop);
  run.result.samples += run.probes->samples;
  run.result.rays += run.probes->rays;
  run.dropped += run.probes->dropped;
  run.report.probes = &*run.probes;
  OutputStream outputs(run.control, run.result.outputs, run.output_names);
  for (bake::BakeOutput& out : probe_volume_outputs(*run.probes, run.color_space)) outputs.push_back(std::move(out));
}

// A probes job: the probes' error is the bake's.
void bake_probes_only(LightmapBakeRun& run) {
  try {
    bake_probes(run);
  } catch (const bake::OutOfTime&) {
    throw out_of_time_in_set_up(run);
  }
  LightmapBakeResult& result = run.result;
  result.error_estimate = run.probes->rms_error;
  if (result.error_estimate >= 0)
    result.curve.push_back({seconds_since(run.t0), result.samples, result.error_estimate});
  result.seconds = seconds_since(run.t0);
  write_report(run);
  run.progress(1.0, "done", result.error_estimate);
}

void write_outputs(LightmapBakeRun& run) {
  std::vector<LightmapMemory> memory;
  uint64_t held = 0;
  for (const LightmapState& m : run.maps) {
    memory.push_back(lightmap_memory(m.texels, lightmap_state_bytes(run.in.ao, run.in.directional, !m.traced.empty())));
    held += memory.back().total_bytes;
  }
  std::optional<StageTimer> timer(std::in_place, run.report.stages, "outputs");
  for (size_t i = 0; i < run.maps.size(); ++i) {
    const LightmapState& m = run.maps[i];
    run.cancel_only.check();
    ChartIds charts(run.scene());
    const Clock::time_point t0 = Clock::now();
    const LightmapResults r = collect_results(m, result_channels(run.in), {&run.scene(), &run.materials, &charts});
    if (run.in.denoise) run.report.denoise_seconds += seconds_since(t0);  // the guides, mostly
    const uint64_t seam_bytes = write_lightmap(run, r, m.leaks, memory[i]);
    run.result.memory.held_peak_bytes =
        std::max<uint64_t>(run.result.memory.held_peak_bytes, held + r.bytes() + seam_bytes);
  }
  timer.reset();  // recorded before the report that lists it
  if (run.in.probes.enabled()) bake_probes(run);
  run.result.seconds = seconds_since(run.t0);
  write_report(run);
  if (run.atlas) write_manifest(run);
  run.progress(1.0, "done", run.result.error_estimate);
}

// ---- Tiled: a page a tile at a time (memory_estimate.h's plan) ----

// One page of a tiled bake: its size and its tiles' bins of triangles.
struct TiledPage {
  std::string name;
  int size = 0;
  TileBins bins;
};

std::vector<TiledPage> bin_pages(LightmapBakeRun& run, const std::vector<std::vector<uint8_t>>& bake_mask) {
  std::vector<TiledPage> pages;
  for (const std::string& name : lightmap_names(run.scene())) {
    TiledPage page;
    page.name = name;
    page.size = lightmap_resolution(run, name);
    RasterOptions raster;
    raster.width = raster.height = page.size;
    raster.bake_mask = &bake_mask;
    run.stage = "binning the triangles of lightmap '" + name + "' into tiles";
    page.bins = bin_triangles(run.scene(), name, raster, run.memory.tile_size, run.stop);
    pages.push_back(std::move(page));
  }
  if (pages.empty()) {
    throw bake::InvalidInput("",
                             "nothing to bake: no instance has a lightmap (meshes need lightmap UVs, TEXCOORD_1 "
                             "or TEXCOORD_0, or generate_uvs other than never, and instances with bake set); " +
                                 run.checked.report.summary());
  }
  return pages;
}

// The sum of the luminances of the tile's valid texels with estimates, and how many: the brightness prior of the
// page's next tiles (LightmapImage::set_brightness_prior).
std::pair<double, size_t> luminance_sum(const LightmapImage& img) {
  double sum = 0;
  size_t n = 0;
  for (size_t t = 0; t < img.texel_count(); ++t) {
    if (!img.valid(t) || img.count(t) == 0) continue;
    sum += luminance(img.mean(t));
    ++n;
  }
  return {sum, n};
}

// A tile not sampled, reached after the time limit or left out by its budget: its texels for their validity and
// guides only, no ray leaving them. Coverage, and so validity, does not depend on the pattern (texels.h): a 1×1
// pattern, one point per texel and covering triangle, gives the same valid texels as the sampled tiles' 2×2 with
// about a quarter of their samples.
void rasterize_unsampled(LightmapBakeRun& run, const TiledPage& page, RasterOptions raster, LightmapTexels& texels) {
  const StageTimer timer(run.report.stages, "rasterization");
  raster.samples_per_axis = 1;
  rasterize_lightmap_into(texels, run.scene(), page.name, raster, run.cancel_only);
}

// Rasterizes a tile and, if `probe_next` still says so once that is measured, resolves its leaks: true when the tile
// is to be sampled. False with `texels` this tile's when it is not, false with `texels` not this tile's when the time
// limit ran out first (after which nothing but a cancel stops the tile).
bool tile_texels(LightmapBakeRun& run, const TiledPage& page, const RasterOptions& raster, const TracerRayQuery& query,
                 const LeakScope& scope, LightmapTexels& texels, LeakReport& leaks,
                 const std::function<bool(double raster_seconds)>& probe_next) {
  try {
    run.stage = "rasterization of lightmap '" + page.name + "'";
    std::optional<StageTimer> timer(std::in_place, run.report.stages, "rasterization");
    const Clock::time_point t0 = Clock::now();
    rasterize_lightmap_into(texels, run.scene(), page.name, raster, run.stop);
    if (!probe_next(seconds_since(t0))) return false;
    match_tracer_offsets(texels, *run.tracer);
    run.stage = "leak probes of lightmap '" + page.name + "'";
    timer.emplace(run.report.stages, "leak_probes");
    const std::vector<uint8_t> probe = scope.probe_mask(texels.samples, run.stop);
    leaks = fix_leaks(texels, query, LeakOptions{}, run.stop, &probe);
    return true;
  } catch (const bake::OutOfTime&) {
    if (run.result.samples == 0) throw;  // before the first sample: the set-up ran out (out_of_time_in_set_up)
  }
  texels.width = 0;  // rasterized for sampling, perhaps probed in part: rasterized anew as an unsampled tile
  leaks = LeakReport{};
  return false;
}

// What the tiles of a bake share while they are baked one after another.
struct TileRun {
  LightmapBakeRun& run;
  const std::vector<std::vector<uint8_t>>& bake_mask;
  const LeakScope& scope;
  const TracerRayQuery query;
  const SamplingOptions options;
  const BakeStateBytes state_bytes;
  double total_coverage = 0;  // the UV area of every tile of every page
  double remaining = 0;       // of the tiles not yet sampled
  ErrorTotals done{};         // over the tiles sampled so far, each as it ended
  LightmapTexels spare{};     // the last tile's texels, whose storage the next tile's rasterization reuses
  TileTimeBudget budget{false};
  double page_texels_left = 0;  // of the pages whose outputs are still to be written

  bool limited() const { return options.deadline != Clock::time_point::max(); }
  double seconds_left() const { return std::chrono::duration<double>(options.deadline - Clock::now()).count(); }
  // Whether the last tile was left unsampled (left_out).
  bool sampling_over() const { return run.result.time_budget.sampling_ended_seconds >= 0; }
  // Where the tile covering `share` stands, for the budget.
  TileOutlook outlook(double share) const {
    return {seconds_left(), share, std::max(0.0, remaining - share), page_texels_left};
  }
};

// A page's tally while its tiles are baked.
struct PageTally {
  LeakReport leaks;
  size_t samples = 0, valid = 0;
  uint64_t held = 0;                      // the most held at once: a tile's state and the page's results
  std::pair<double, size_t> prior{0, 0};  // the brightness of its tiles so far (luminance_sum)
};

void add_leaks(LeakReport& into, const LeakReport& tile) {
  into.samples += tile.samples;
  into.pruned += tile.pruned;
  into.moved += tile.moved;
  into.invalidated += tile.invalidated;
  into.texels_invalidated += tile.texels_invalidated;
  into.rays += tile.rays;
}

// Marks the start of a run of tiles left unsampled, and what was then forecast to follow, for the report.
void left_out(TileRun& t) {
  if (t.sampling_over()) return;
  LightmapBakeResult::TimeBudget& b = t.run.result.time_budget;
  b.sampling_ended_seconds = seconds_since(t.run.t0);
  b.forecast_seconds = t.budget.after(t.remaining, t.page_texels_left);
}

// Whether the tile covering `share` is to be sampled: before the time limit, while its budget has room for its
// set-up and what must follow (tile_time_budget.h). A tile left out does not end the sampling: the forecast that left
// it out may rest on priors that the next page's measured rates correct, and a smaller tile may still fit. The
// report keeps when the last run of tiles left out began and what was then forecast to follow.
bool sample_next(TileRun& t, double share) {
  if (!t.limited()) return true;
  LightmapBakeResult::TimeBudget& b = t.run.result.time_budget;
  if (t.budget.should_sample(t.outlook(share))) {
    b.sampling_ended_seconds = -1;  // a tile sampled after a run left out: that run did not end the sampling
    return true;
  }
  left_out(t);
  return false;
}

// How a tile was set up: to be sampled, or not; if not, whether at one point per texel (or rasterized to be sampled
// and then left out by its budget).
struct TileSetUp {
  bool sample = false;
  bool unsampled_raster = false;
};

// The tile's texels, leaks resolved when it is to be sampled (as its budget says).
LightmapTexels tile_texels_to_bake(TileRun& t, const TiledPage& page, const RasterOptions& raster, double share,
                                   LeakReport& leaks, TileSetUp& set_up) {
  LightmapBakeRun& run = t.run;
  LightmapTexels texels = std::move(t.spare);
  texels.width = 0;  // not yet this tile's
  double raster_seconds_taken = 0;
  const auto probe_next = [&](double raster_seconds) {
    raster_seconds_taken = raster_seconds;
    t.budget.sampled_raster(raster_seconds, share);
    if (!t.limited()) return true;
    const bool probe = t.budget.should_probe(t.outlook(share));
    if (!probe) left_out(t);
    return probe;
  };
  try {
    const Clock::time_point t0 = Clock::now();
    set_up.sample =
        sample_next(t, share) && tile_texels(run, page, raster, t.query, t.scope, texels, leaks, probe_next);
    if (set_up.sample) {
      t.budget.probes(seconds_since(t0) - raster_seconds_taken, share);
    } else {
      left_out(t);  // by the budget, or by the limit itself during the set-up
      set_up.unsampled_raster = texels.width == 0;
      if (set_up.unsampled_raster) rasterize_unsampled(run, page, raster, texels);
    }
  } catch (const bake::OutOfTime&) {
    throw out_of_time_in_set_up(run);
  }
  run.check_cancel();
  return texels;
}

// Samples a tile that covers `share` of the pages' UV area until its target or the time its budget gives it
// (tile_time_budget.h).
void sample_tile(TileRun& t, std::vector<LightmapState>& tile, double share) {
  LightmapBakeRun& run = t.run;
  const double before = (t.total_coverage - t.remaining) / std::max(t.total_coverage, 1e-300);
  const double weight = share / std::max(t.total_coverage, 1e-300);
  const StageTimer timer(run.report.stages, "passes");
  const Clock::time_point t0 = Clock::now();
  SamplingOptions o = t.options;
  if (t.limited()) {
    const double s = t.budget.sampling_seconds(t.outlook(share));
    o.deadline = std::min(o.deadline, time_after(t0, s));
  }
  run_passes(run, tile, o, false, [&](uint64_t pass) {
    const ErrorTotals e = error_totals(run, tile);
    // The first pass's coverage: the tile's, times the share of its texels it reached before a cut.
    if (pass == 0 && e.valid > 0) {
      t.budget.first_pass(seconds_since(t0), share * static_cast<double>(e.estimated) / static_cast<double>(e.valid));
    }
    run.progress(0.05 + 0.9 * (before + weight * e.done()),
                 "tile " + std::to_string(run.result.memory.tiles) + ", pass " + std::to_string(pass + 1), e.rms());
  });
  t.done.add(error_totals(run, tile));
  run.result.curve.push_back({seconds_since(run.t0), run.result.samples, t.done.rms()});
}

// Samples tile k of page `pi`, its texels set up, and collects it into the page's results.
void sample_and_collect(TileRun& t, TiledPage& page, size_t pi, size_t k, LightmapTexels texels,
                        const LeakReport& leaks, const ResultsContext& context, LightmapResults& results,
                        PageTally& tally) {
  LightmapBakeRun& run = t.run;
  const double share = page.bins.coverage[k];
  const RasterOptions::Window window = page.bins.window(k);
  const Clock::time_point t0 = Clock::now();
  std::vector<LightmapState> tile;
  tile.push_back(make_lightmap_state(page.name, std::move(texels), leaks, run.in.ao, run.in.directional));
  LightmapState& m = tile.front();
  m.page = static_cast<uint32_t>(pi);
  m.x0 = window.x0;
  m.y0 = window.y0;
  m.page_width = page.size;
  m.image.set_brightness_prior(tally.prior.first, tally.prior.second);
  const Clock::time_point p0 = Clock::now();
  sample_tile(t, tile, share);
  const double passes = seconds_since(p0);
  t.remaining -= share;
  const std::pair<double, size_t> lum = luminance_sum(m.image);
  tally.prior = {tally.prior.first + lum.first, tally.prior.second + lum.second};
  collect_results(m, m.x0, m.y0, context, results);
  t.spare = std::move(m.texels);
  t.budget.sampled_rest(seconds_since(t0) - passes, share);
}

// Rasterizes, probes, samples (before the deadline) and collects tile k of page `pi` into the page's results.
void bake_tile(TileRun& t, TiledPage& page, size_t pi, size_t k, LightmapResults& results, ChartIds& charts,
               PageTally& tally) {
  LightmapBakeRun& run = t.run;
  RasterOptions raster;
  raster.width = raster.height = page.size;
  raster.bake_mask = &t.bake_mask;
  raster.window = page.bins.window(k);
  raster.triangles = &page.bins.triangles[k];
  LeakReport leaks;
  TileSetUp set_up;
  const double share = page.bins.coverage[k];
  const Clock::time_point t0 = Clock::now();
  LightmapTexels texels = tile_texels_to_bake(t, page, raster, share, leaks, set_up);
  run.result.rays += leaks.rays;
  run.result.probe_rays += leaks.rays;
  add_leaks(tally.leaks, leaks);
  tally.samples += texels.samples.size();
  tally.valid += texels.valid_count();
  // A sampled tile holds its sampling state beside its texels (lightmap_memory); an unsampled one its texels alone.
  const uint64_t tile_bytes = set_up.sample ? lightmap_memory(texels, t.state_bytes).total_bytes : texels.bytes();
  tally.held = std::max<uint64_t>(tally.held, tile_bytes + results.bytes());
  ++run.result.memory.tiles;
  const ResultsContext context{&run.scene(), &run.materials, &charts};
  if (set_up.sample) {
    sample_and_collect(t, page, pi, k, std::move(texels), leaks, context, results, tally);
  } else {
    // No state: a tile without estimates has nothing in it but its texels (collect_unsampled).
    ++run.result.memory.tiles_unsampled;
    t.remaining -= share;
    collect_unsampled(texels, raster.window.x0, raster.window.y0, context, results);
    t.spare = std::move(texels);
    if (set_up.unsampled_raster) t.budget.unsampled_tile(seconds_since(t0), share);
  }
  run.check_cancel();
}

// Bakes page `pi` a tile at a time and writes its outputs.
void bake_page(TileRun& t, TiledPage& page, size_t pi) {
  LightmapBakeRun& run = t.run;
  LightmapResults results(page.name, page.size, page.size, result_channels(run.in));
  ChartIds charts(run.scene());
  PageTally tally;
  for (size_t k = 0; k < page.bins.tile_count(); ++k) {
    if (page.bins.triangles[k].empty()) continue;  // no triangle: every texel stays invalid
    bake_tile(t, page, pi, k, results, charts, tally);
  }
  page.bins = TileBins{};
  t.spare = LightmapTexels{};  // not held while the outputs are made, whose peak is the bake's
  run.result.memory.held_peak_bytes = std::max(run.result.memory.held_peak_bytes, tally.held);
  run.cancel_only.check();
  LightmapMemory memory = lightmap_memory(results.texel_count(), tally.samples, tally.valid, t.state_bytes);
  memory.total_bytes = tally.held;
  const Clock::time_point t0 = Clock::now();
  const StageTimer timer(run.report.stages, "outputs");
  const uint64_t seam_bytes = write_lightmap(run, results, tally.leaks, memory);
  run.result.memory.held_peak_bytes =
      std::max<uint64_t>(run.result.memory.held_peak_bytes, results.bytes() + seam_bytes);
  const double texels = static_cast<double>(results.texel_count());
  t.budget.page_written(seconds_since(t0), texels);
  t.page_texels_left = std::max(0.0, t.page_texels_left - texels);
}

// The error curve's last point, over every texel of every page under each page's final brightness, the estimate
// (unknown, −1, when no tile was sampled, as in sample_adaptively), the report and the manifest.
void finish_tiles(LightmapBakeRun& run) {
  LightmapBakeResult& result = run.result;
  ErrorTotals final_totals;
  for (const LightmapReportEntry& e : run.report.lightmaps) final_totals.add(e.error);
  if (final_totals.estimated > 0) {
    result.curve.push_back({seconds_since(run.t0), result.samples, final_totals.rms()});
  }
  result.error_estimate = result.curve.empty() ? -1.0 : std::max(-1.0, result.curve.back().error);
  LightmapBakeResult::TimeBudget& b = result.time_budget;
  if (b.sampling_ended_seconds >= 0) b.after_seconds = seconds_since(run.t0) - b.sampling_ended_seconds;
  if (run.in.probes.enabled()) bake_probes(run);
  result.seconds = seconds_since(run.t0);
  write_report(run);
  if (run.atlas) write_manifest(run);
  run.progress(1.0, "done", result.error_estimate);
}

void bake_tiles(LightmapBakeRun& run) {
  std::vector<std::vector<uint8_t>> bake_mask;
  for (const auto& t : run.checked.triangles) bake_mask.push_back(t.bake);
  std::vector<TiledPage> pages;
  std::optional<LeakScope> scope;
  try {
    {
      const StageTimer timer(run.report.stages, "tile_binning");
      pages = bin_pages(run, bake_mask);
    }
    const StageTimer timer(run.report.stages, "leak_scope");
    run.stage = "leak scope";
    scope.emplace(run.scene(), LeakScopeOptions{}, run.stop);
    run.report.leak_scope = scope->summary();
  } catch (const bake::OutOfTime&) {
    throw out_of_time_in_set_up(run);
  }
  TileRun t{run,
            bake_mask,
            *scope,
            TracerRayQuery(*run.tracer, run.scene(), run.in.ray_log),
            sampling_options(run),
            lightmap_state_bytes(run.in.ao, run.in.directional, false)};
  for (const TiledPage& p : pages) {
    for (double c : p.bins.coverage) t.remaining += c;
    t.page_texels_left += static_cast<double>(p.size) * static_cast<double>(p.size);
  }
  t.total_coverage = t.remaining;
  t.budget = TileTimeBudget(run.in.denoise);
  run.progress(0.05, "tiles", -1);
  for (size_t pi = 0; pi < pages.size(); ++pi) bake_page(t, pages[pi], pi);
  LightmapBakeResult::TimeBudget& b = run.result.time_budget;
  b.on = t.limited();
  b.sampled_rate = t.budget.sampled_rate();
  b.first_pass_rate = t.budget.first_pass_rate();
  b.unsampled_rate = t.budget.unsampled_rate();
  b.output_rate = t.budget.output_rate();
  finish_tiles(run);
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
  if (in.tile_size != 0) {
    const bounds::Range tile{static_cast<double>(kMinTileSize), 16384};
    if (auto e = check_range("tile_size", in.tile_size, tile)) return e;
  }
  if (in.atlas.texel_density != 0) {
    if (auto e = check_atlas_options(in.atlas)) return e->under("atlas");
  }
  if (!in.textures.empty() && !in.scene.textures.empty()) {
    return InvalidInput("textures", "give textures either decoded in the scene or encoded, not both");
  }
  if (auto e = check_range("media", static_cast<double>(in.media.size()), bounds::kLightmapMedia.real())) return e;
  if (auto e = plan::check_forced_names(in.force_effects, plan::lightmap_effect_names())) return e;
  if (in.probes.enabled() || !in.lightmaps) {
    if (auto e = validate(in.probes)) return e;
  }
  if (in.full_simulation && !in.force_effects.empty()) {
    return InvalidInput("force_effects", "a full simulation simulates everything; leave force_effects empty");
  }
  return std::nullopt;
}

LightmapBakeResult bake_lightmaps(const LightmapBakeInput& in, const bake::BakeControl& control) {
  if (auto problem = validate(in)) throw *problem;
  LightmapBakeRun run(in, control);
  try {
    {
      const StageTimer timer(run.report.stages, "scene");
      prepare_scene(run);
    }
    {
      const StageTimer timer(run.report.stages, "plan");
      plan_memory(run);
      plan_bake(run);
    }
    prepare_transport(run);
    if (run.in.lightmaps && run.memory.tile_size == 0) rasterize_texels(run);
  } catch (const bake::OutOfTime&) {
    throw out_of_time_in_set_up(run);
  }
  if (!run.in.lightmaps) {
    bake_probes_only(run);
  } else if (run.memory.tile_size > 0) {
    bake_tiles(run);
  } else {
    sample_adaptively(run);
    write_outputs(run);
  }
  return std::move(run.result);
}

}  // namespace kiln::lightmap
