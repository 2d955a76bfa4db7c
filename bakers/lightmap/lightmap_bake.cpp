#include "bakers/lightmap/lightmap_bake.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "bakers/bake/number_format.h"
#include "bakers/bake/range_check.h"
#include "bakers/image/color.h"
#include "bakers/image/display_png.h"
#include "bakers/image/exr.h"
#include "bakers/image/png.h"
#include "bakers/image/texture_decode.h"
#include "bakers/lightmap/integrator.h"
#include "bakers/lightmap/leaks.h"
#include "bakers/lightmap/lightmap_image.h"
#include "bakers/lightmap/memory.h"
#include "bakers/lightmap/texels.h"
#include "bakers/lightmap/tracer_query.h"
#include "bakers/plan/lightmap_plan.h"
#include "bakers/scene/light_sampler.h"
#include "bakers/scene/ray_offset.h"
#include "bakers/scene/scene_check.h"
#include "bakers/scene/tracer.h"

namespace kiln::lightmap {
namespace {

using bake::format_number;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

void check_cancel(const bake::BakeControl& control) {
  if (control.cancel && control.cancel->load()) throw bake::BakeCancelled();
}

// A seed per (bake seed, lightmap, texel, pass): every estimate has its own stream, whatever thread computes it, so
// the bytes do not depend on scheduling.
uint64_t mix(uint64_t a, uint64_t b) {
  uint64_t x = a * 0x9E3779B97F4A7C15ull ^ (b + 0x632BE59BD9B4E019ull + (a << 6) + (a >> 2));
  x ^= x >> 31;
  x *= 0xBF58476D1CE4E5B9ull;
  x ^= x >> 27;
  return x;
}

// The receiver of a texel sample, with the lift that clears its own float triangle.
Receiver receiver(const TexelSample& t) {
  Receiver r;
  r.surface = t.surface();
  r.ns = dot(t.shading_normal, t.geometric_normal) > 0 ? t.shading_normal : t.geometric_normal;
  return r;
}

// Diffuse reflectance at a texel sample (for NAME_radiance.exr, ρE/π): the material's directional-hemispherical
// albedo at normal incidence with its base colour and texture — what a Lambertian approximation of it reflects.
Rgb reflectance(const scene::Scene& s, const std::vector<ShadingMaterial>& materials, const TexelSample& t) {
  const scene::Mesh& mesh = s.meshes[t.triangle.mesh];
  const uint32_t index = mesh.material.empty() ? 0 : mesh.material[t.triangle.triangle];
  const ShadingMaterial& m = materials[index];
  Rgb tint = m.base_color * m.texture_average;
  if (m.texture >= 0 && !mesh.uv.empty()) {
    const scene::Texture& tex = s.textures[m.texture];
    const uint32_t* idx = &mesh.indices[3 * t.triangle.triangle];
    const double b1 = t.barycentric.x, b2 = t.barycentric.y, b0 = 1 - b1 - b2;
    const Point2 uv{b0 * mesh.uv[idx[0]].x + b1 * mesh.uv[idx[1]].x + b2 * mesh.uv[idx[2]].x,
                    b0 * mesh.uv[idx[0]].y + b1 * mesh.uv[idx[1]].y + b2 * mesh.uv[idx[2]].y};
    const int x = std::clamp(static_cast<int>((uv.x - std::floor(uv.x)) * tex.width), 0, tex.width - 1);
    const int y = std::clamp(static_cast<int>((uv.y - std::floor(uv.y)) * tex.height), 0, tex.height - 1);
    tint = m.base_color * tex.texels[static_cast<size_t>(y) * tex.width + x];
  }
  if (m.lambertian) return m.lambertian->A + m.lambertian->B * tint;  // the same albedo in every direction
  // The albedo of the material seen from the normal (μ = 1), with the tint on its diffuse part.
  const Vec3 n{0, 0, 1};
  Rgb albedo;
  constexpr int kDirections = 64;  // a fixed stratified cosine quadrature: ample for a preview-grade ρ
  for (int i = 0; i < kDirections; ++i) {
    for (int j = 0; j < 4; ++j) {
      const Vec3 wi = sample_cosine_hemisphere({(i + 0.5) / kDirections, (j + 0.5) / 4});
      albedo += m.bsdf->eval(n, wi, tint) * kPi;  // f cos / (cos/π)
    }
  }
  return albedo / (4.0 * kDirections);
}

image::FloatImage texel_image(const LightmapImage& img, int channels, const std::vector<std::string>& names,
                              const std::function<void(size_t, float*)>& fill) {
  image::FloatImage out;
  out.width = img.width();
  out.height = img.height();
  out.channels = channels;
  out.channel_names = names;
  out.pixels.assign(static_cast<size_t>(out.width) * out.height * channels, 0.0f);
  for (size_t t = 0; t < img.texel_count(); ++t) {
    if (img.valid(t)) fill(t, &out.pixels[t * channels]);
  }
  return out;
}

// The irradiance through the display transform, exposed by image::auto_exposure's rule over the valid texels
// (the median to mid-grey, else the mean, else 1); the Description and kiln:exposure_rule say which applied.
std::string preview_png(const image::FloatImage& irradiance, const std::vector<uint8_t>& validity,
                        const std::string& color_space, const std::string& name) {
  // The key: the valid texels' luminances (invalid texels are not part of any surface).
  std::vector<double> luma;
  for (size_t t = 0; t < validity.size(); ++t) {
    if (!validity[t]) continue;
    const float* p = &irradiance.pixels[t * 3];
    luma.push_back(luminance(Rgb(p[0], p[1], p[2])));
  }
  const image::AutoExposure auto_exposure = image::auto_exposure(std::move(luma));
  const double exposure = auto_exposure.multiplier;
  const std::string rule = image::describe_exposure(auto_exposure, "valid texel", "every valid texel is black");
  image::Png8Image png =
      image::display_png8(irradiance.pixels, irradiance.width, irradiance.height, exposure, color_space);
  png.metadata["Description"] = "kiln lightmap " + name + ": irradiance, exposure " + rule;
  png.metadata["kiln:exposure"] = format_number(exposure);
  png.metadata["kiln:exposure_rule"] = rule;
  return image::encode_png(png);
}

struct Lightmap {
  std::string name;
  LightmapTexels texels;
  std::vector<Receiver> receivers;  // parallel to texels.samples
  LightmapImage image;
  LeakReport leaks;
  std::vector<Rgb> ao_sum;                 // per texel, sum over estimates (AO in every channel)
  std::vector<std::array<Rgb, 4>> sh_sum;  // per texel
  std::vector<std::array<double, 4>> sh_y2;  // per texel, sum over estimates of each coefficient's luminance²
  std::vector<uint32_t> attempts;          // per texel, estimates tried (kept or dropped)
};

// What a Lightmap holds beside its texels and image, per texel and per sample, for the report: the element sizes
// of its vectors (the AO and SH sums only when those outputs are asked for), read off the members themselves.
template <class Vector>
constexpr size_t element_bytes() {
  return sizeof(typename Vector::value_type);
}
BakeStateBytes state_bytes(const LightmapBakeInput& in) {
  BakeStateBytes b;
  b.per_texel = element_bytes<decltype(Lightmap::attempts)>();
  if (in.ao) b.per_texel += element_bytes<decltype(Lightmap::ao_sum)>();
  if (in.directional) {
    b.per_texel += element_bytes<decltype(Lightmap::sh_sum)>() + element_bytes<decltype(Lightmap::sh_y2)>();
  }
  b.per_sample = element_bytes<decltype(Lightmap::receivers)>();
  return b;
}

// The estimated relative error of a texel's SH from the spread of its n estimates (luminance throughout): the
// standard error of L00 relative to L00, and that of the L1 vector relative to √3·L00 (the largest |L1| a
// non-negative radiance has: all of it arriving from one direction), whichever is larger. +∞ below two estimates;
// 0 for a black texel (all estimates 0).
double sh_relative_error(const std::array<Rgb, 4>& sum, const std::array<double, 4>& sum_y2, uint32_t n) {
  if (n < 2) return std::numeric_limits<double>::infinity();
  double se[4];
  for (int c = 0; c < 4; ++c) se[c] = standard_error_of_mean(luminance(sum[c]), sum_y2[c], n);
  const double l00 = luminance(sum[0]) / n;
  if (!(l00 > 0)) return 0;  // no radiance arrives: every estimate was 0
  return std::max(se[0] / l00, std::hypot(se[1], se[2], se[3]) / (std::sqrt(3.0) * l00));
}

// What one work item's estimates add to a texel, accumulated by its worker alone and then merged (merge()).
struct Partial {
  Rgb sum;                       // of the accepted irradiance estimates
  double sum_y2 = 0;             // of their luminances squared
  uint32_t count = 0, tried = 0;  // accepted; tried (accepted or dropped)
  Rgb ao;
  std::array<Rgb, 4> sh{};
  std::array<double, 4> sh_y2{};

  // One accepted estimate: irradiance E, AO, and (`directional`) the SH coefficients summed with total sample weight
  // `weight`.
  void add(const Rgb& E, const Rgb& ao_estimate, const std::array<Rgb, 4>& sh_weighted, double weight,
           bool directional) {
    sum += E;
    const double y = luminance(E);
    sum_y2 += y * y;
    ++count;
    ao += ao_estimate;
    if (!directional) return;
    for (int c = 0; c < 4; ++c) {
      const Rgb coefficient = sh_weighted[c] / weight;
      sh[c] += coefficient;
      const double yc = luminance(coefficient);
      sh_y2[c] += yc * yc;
    }
  }
};

void merge(Lightmap& m, size_t t, const Partial& p) {
  m.attempts[t] += p.tried;
  m.image.merge(t, p.sum, p.sum_y2, p.count);
  if (!m.ao_sum.empty()) m.ao_sum[t] += p.ao;
  if (!m.sh_sum.empty()) {
    for (int c = 0; c < 4; ++c) {
      m.sh_sum[t][c] += p.sh[c];
      m.sh_y2[t][c] += p.sh_y2[c];
    }
  }
}

std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      out += buf;
    } else {
      out += c;
    }
  }
  return out + "\"";
}

}  // namespace

std::optional<bake::InvalidInput> validate(const LightmapBakeInput& in) {
  using bake::InvalidInput;
  const auto range = [](const std::string& field, double v, double lo, double hi) {
    return bake::check_range(field, v, lo, hi);
  };
  if (auto e = range("resolution", in.resolution, 4, 8192)) return e;
  for (const auto& [name, r] : in.resolutions) {
    if (auto e = range("resolutions[" + name + "]", r, 4, 8192)) return e;
  }
  if (auto e = range("padding", in.padding, 0, 64)) return e;
  if (auto e = bake::check_range("target_error", in.target_error, 0, 1, true)) return e;
  if (auto e = range("max_samples", static_cast<double>(in.max_samples), 1, 1 << 20)) return e;
  if (auto e = range("min_samples", static_cast<double>(in.min_samples), 1, static_cast<double>(in.max_samples))) {
    return e;
  }
  if (auto e = range("time_limit_seconds", in.time_limit_seconds, 0, 7 * 86400)) return e;
  if (auto e = range("max_bounces", in.max_bounces, 0, 1024)) return e;
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
  const auto t0 = Clock::now();
  LightmapBakeResult result;
  double last_fraction = 0;
  auto progress = [&](double fraction, const std::string& stage, double error) {
    check_cancel(control);
    if (!control.progress) return;
    bake::BakeProgress p;
    last_fraction = std::max(last_fraction, std::clamp(fraction, 0.0, 1.0));  // never decreasing
    p.fraction = last_fraction;
    p.samples = result.samples;
    p.error_estimate = error;
    p.stage = stage;
    control.progress(p);
  };

  // 1. The scene: textures and environment decoded, then checked and cleaned.
  scene::Scene input = in.scene;
  for (const EncodedTexture& t : in.textures) {
    image::DecodedTexture d = image::decode_texture(t.bytes, t.color_space, t.name);
    if (d.replaced + d.clamped > 0) {
      result.skipped.push_back("texture " + t.name + ": " + std::to_string(d.replaced) +
                               " texels not usable as a reflectance (NaN, infinite or negative) set to 0, " +
                               std::to_string(d.clamped) + " above 1 clamped to 1");
    }
    input.textures.push_back({t.name, d.width, d.height, std::move(d.texels)});
  }
  std::string color_space = image::ColorConfig::active().working_space();
  if (!in.environment_image.empty()) {
    const envmap::EnvironmentInput env = envmap::decode_environment(in.environment_image, in.environment_decode);
    input.environment = scene::Environment{};
    input.environment.width = env.image.width;
    input.environment.height = env.image.height;
    input.environment.equirect = env.image.pixels;
    input.environment.rotation_degrees = env.rotation_degrees;
    if (env.sanitized.total() > 0) {
      result.skipped.push_back("environment: " + std::to_string(env.sanitized.total()) +
                               " texels not usable as radiance (NaN, infinite or negative) replaced by the "
                               "documented rule of bakers/envmap/env_input.h");
    }
  }
  scene::CheckedScene checked = scene::check_scene(input);
  const scene::Scene& s = checked.scene;
  for (const scene::Problem& p : checked.report.problems) {
    result.skipped.push_back(std::string(scene::to_string(p.kind)) + ": " + p.what + "; " + p.action);
  }
  progress(0.01, "scene", -1);

  // 2. The plan.
  plan::LightmapPlanOptions plan_options;
  plan_options.target_error = in.target_error;
  plan_options.max_bounces = in.max_bounces;
  plan_options.force_effects = in.force_effects;
  const plan::LightmapPlan plan =
      in.full_simulation ? plan::full_plan(s, plan_options) : plan::plan_lightmap(s, plan_options);
  result.plan = plan.decisions;

  // 3. Tracer, lights, materials.
  const scene::Tracer tracer(s);
  scene::LightSamplingOptions light_options;
  light_options.point_lights = plan.point_lights;
  light_options.spot_lights = plan.spot_lights;
  light_options.directional_lights = plan.directional_lights;
  light_options.area_lights = plan.area_lights;
  light_options.emissive_triangles = plan.emissive_triangles;
  light_options.environment = plan.environment_sampling;
  light_options.environment_importance_map = plan.environment_importance_map;
  const scene::SceneLights lights(s, light_options);
  const std::vector<ShadingMaterial> materials = shading_materials(s, plan);
  TransportContext ctx;
  ctx.scene = &s;
  ctx.tracer = &tracer;
  ctx.lights = &lights;
  ctx.plan = &plan;
  ctx.materials = &materials;
  ctx.ray_log = in.ray_log;
  ctx.directional = in.directional;
  prepare_context(ctx);
  if (in.ao) {
    // AO within a tenth of the scene's size: the usual contact-shadow scale, and independent of the scene's unit.
    ctx.ao_distance = 0.1 * scene::scene_bounding_radius(s);
  }
  progress(0.03, "tracer", -1);

  // 4. Texels of every lightmap, leaks resolved.
  std::vector<Lightmap> maps;
  const TracerRayQuery query(tracer, s, in.ray_log);
  // Triangles the scene check keeps for tracing but not for baking (UVs outside [0, 1], zero UV area).
  std::vector<std::vector<uint8_t>> bake_mask;
  for (const auto& t : checked.triangles) bake_mask.push_back(t.bake);
  for (const std::string& name : lightmap_names(s)) {
    const auto it = in.resolutions.find(name);
    const int res = it != in.resolutions.end() ? it->second : in.resolution;
    RasterOptions raster;
    raster.width = raster.height = res;
    raster.bake_mask = &bake_mask;
    LightmapTexels texels = rasterize_lightmap(s, name, raster);
    const LeakReport leaks = fix_leaks(texels, query, LeakOptions{});
    result.rays += leaks.rays;
    result.probe_rays += leaks.rays;
    std::vector<uint8_t> validity = texels.validity();
    Lightmap m{name, std::move(texels), {}, LightmapImage(name, res, res, std::move(validity)), leaks, {}, {}, {}, {}};
    m.attempts.assign(m.texels.texel_count(), 0);
    m.receivers.reserve(m.texels.samples.size());
    for (const TexelSample& t : m.texels.samples) m.receivers.push_back(receiver(t));
    if (in.ao) m.ao_sum.assign(m.texels.texel_count(), Rgb{});
    if (in.directional) {
      m.sh_sum.assign(m.texels.texel_count(), {});
      m.sh_y2.assign(m.texels.texel_count(), {});
    }
    maps.push_back(std::move(m));
    check_cancel(control);
  }
  if (maps.empty()) {
    throw std::runtime_error("nothing to bake: no instance has a lightmap (meshes need lightmap UVs, TEXCOORD_1 or "
                             "TEXCOORD_0, and instances with bake set); " + checked.report.summary());
  }
  progress(0.05, "texels", -1);

  // 5. Adaptive passes: every estimate is one path per sample point of the texel, weighted by the point's share of
  // it. Each pass gives every texel still short of its goal a batch of estimates: up to min_samples first, then as
  // many as its (pooled) variance says the target needs, up to max_samples. Batches grow with what a texel already
  // has (at most half as many again per pass, at least one), so a bake takes tens of passes rather than thousands
  // (scheduling and the error summary run between passes, on all texels) and the curve still has a point per pass.
  std::atomic<uint64_t> dropped{0};
  // Rule of three: n estimates that never met some contribution only say that its probability per path is below
  // 3/n (95 % confidence). A texel whose estimates barely vary (in the open under a constant sky, or black) would
  // stop at min_samples while missing anything that only some of its paths find; no texel stops before 3/n ≤
  // target, i.e. before anything reaching it through more than a fraction `target` of its paths would have shown.
  // (Texels with real variance need more than this anyway once v > 3·target.)
  const double rare_event_samples = std::ceil(3.0 / in.target_error);
  const auto deadline = in.time_limit_seconds > 0
                            ? t0 + std::chrono::duration_cast<Clock::duration>(
                                       std::chrono::duration<double>(in.time_limit_seconds))
                            : Clock::time_point::max();
  for (uint64_t pass = 0;; ++pass) {
    struct Job {
      uint32_t map;
      uint32_t batch;
      size_t texel;
    };
    // Scheduling is O(texels) per pass: done row-parallel, and the pooled variance only when some texel of the
    // lightmap has its min_samples (budget-bound bakes, min_samples = max_samples, never need it).
    std::vector<Job> active;
    for (size_t mi = 0; mi < maps.size(); ++mi) {
      const Lightmap& m = maps[mi];
      const LightmapImage& img = m.image;
      const int w = img.width(), h = img.height();
      bool any_adaptive = false;
      for (size_t t = 0; t < img.texel_count() && !any_adaptive; ++t) {
        any_adaptive = img.count(t) >= in.min_samples && m.attempts[t] < in.max_samples;
      }
      // The relative variance of one estimate, v = n·(relative standard error)², per texel.
      std::vector<double> v;
      if (any_adaptive) {
        v.assign(img.texel_count(), -1);
        tbb::parallel_for(tbb::blocked_range<size_t>(0, img.texel_count(), 4096),
                          [&](const tbb::blocked_range<size_t>& r) {
                            for (size_t t = r.begin(); t != r.end(); ++t) {
                              if (img.valid(t) && img.count(t) >= 2) {
                                const double e = img.relative_error(t);
                                v[t] = std::isfinite(e) ? e * e * img.count(t) : -1;
                              }
                            }
                          });
      }
      std::vector<std::vector<Job>> rows(h);
      tbb::parallel_for(tbb::blocked_range<int>(0, h, 8), [&](const tbb::blocked_range<int>& ry) {
        for (int y = ry.begin(); y != ry.end(); ++y) {
          for (int x = 0; x < w; ++x) {
            const size_t t = static_cast<size_t>(y) * w + x;
            if (!img.valid(t)) continue;
            // Attempts, not kept estimates, bound the work: a texel whose estimates are all dropped (non-finite)
            // would otherwise be scheduled for ever.
            const uint64_t tried = m.attempts[t];
            if (tried >= in.max_samples) continue;
            const uint64_t n = img.count(t);
            double goal = static_cast<double>(in.min_samples);
            if (n >= in.min_samples) {
              // The samples a texel needs, n = v/target², from v pooled over its 3 × 3 neighbourhood: deciding from
              // the texel's own variance alone biases the result low, since an estimate that has not yet met its
              // rare large samples also looks precise (measured: 1-2 % low at a 2 % target in a furnace).
              // Neighbours are independent estimates of nearly the same variance, which breaks that correlation.
              double sum = 0;
              int count = 0;
              for (int dy = -1; dy <= 1; ++dy) {
                for (int dx = -1; dx <= 1; ++dx) {
                  const int xx = x + dx, yy = y + dy;
                  if (xx < 0 || yy < 0 || xx >= w || yy >= h) continue;
                  const double vv = v[static_cast<size_t>(yy) * w + xx];
                  if (vv >= 0) sum += vv, ++count;
                }
              }
              goal = std::max(count ? sum / count / (in.target_error * in.target_error) : 0, rare_event_samples);
            }
            const double want = std::ceil(goal) - static_cast<double>(n);
            if (!(want >= 1)) continue;
            const uint64_t growth = std::max<uint64_t>(1, tried / 2);
            const uint64_t batch =
                std::min({static_cast<uint64_t>(std::min(want, 1e12)), growth, in.max_samples - tried});
            rows[y].push_back({static_cast<uint32_t>(mi), static_cast<uint32_t>(batch), t});
          }
        }
      });
      for (const std::vector<Job>& row : rows) active.insert(active.end(), row.begin(), row.end());
    }
    if (active.empty()) break;
    // Work items: normally one per texel, whose worker owns the texel and merges into it directly. When few texels
    // remain (late adaptive passes, where batches are large), one texel's batch is split over several items so that
    // every core gets work; their partial sums are merged after the pass. Each item's estimates draw from a stream
    // seeded by (bake seed, lightmap, texel, index of its first estimate): the bytes do not depend on the thread
    // count or the order of execution.
    struct Item {
      uint32_t map, count;
      size_t texel;
      uint64_t first;     // index of the item's first estimate among all the texel's estimates
      int64_t partial;    // into `partials`, or −1: merge directly
    };
    std::vector<Item> items;
    std::vector<Partial> partials;
    // Fixed, not from the thread count (the split decides the streams, so the bytes would follow the machine):
    // enough items for a few dozen cores.
    constexpr size_t spread = 1024;
    if (active.size() >= spread) {
      items.reserve(active.size());
      for (const Job& j : active) items.push_back({j.map, j.batch, j.texel, maps[j.map].attempts[j.texel], -1});
    } else {
      const uint64_t pieces = (spread + active.size() - 1) / active.size();
      for (const Job& j : active) {
        const uint64_t size = std::max<uint64_t>(1, (j.batch + pieces - 1) / pieces);
        const uint64_t start = maps[j.map].attempts[j.texel];
        for (uint64_t done = 0; done < j.batch; done += size) {
          const auto count = static_cast<uint32_t>(std::min<uint64_t>(size, j.batch - done));
          items.push_back({j.map, count, j.texel, start + done, static_cast<int64_t>(partials.size())});
          partials.emplace_back();
        }
      }
    }
    std::atomic<uint64_t> rays{0}, occlusion_rays{0}, paths{0}, general_vertices{0};
    std::atomic<bool> out_of_time{false};
    // Grain: up to 16 items per task, fewer when there are few, so that every core gets work.
    const size_t grain = std::clamp<size_t>(items.size() / 32, 1, 16);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, items.size(), grain), [&](const tbb::blocked_range<size_t>& r) {
      if (control.cancel && control.cancel->load()) return;
      uint64_t local_rays = 0, local_occlusion = 0, local_paths = 0, local_general = 0;
      for (size_t j = r.begin(); j != r.end(); ++j) {
        // The time limit holds inside a pass too: the texels not reached keep what they have.
        if (out_of_time.load(std::memory_order_relaxed)) break;
        if (Clock::now() >= deadline) {
          out_of_time = true;
          break;
        }
        const Item& item = items[j];
        Lightmap& m = maps[item.map];
        const size_t t = item.texel;
        Pcg32 rng(mix(mix(in.seed, item.map), mix(t, item.first)));
        const auto samples = m.texels.at(t);
        Partial p;
        for (uint32_t b = 0; b < item.count; ++b) {
          ++p.tried;
          Rgb E, ao;
          std::array<Rgb, 4> sh{};
          double weight = 0;
          bool bad = false;
          for (size_t k = 0; k < samples.size(); ++k) {
            const Receiver& rec = m.receivers[m.texels.first[t] + k];
            const IrradianceEstimate e = estimate_irradiance(ctx, rec, rng);
            local_rays += e.rays;
            local_occlusion += e.occlusion_rays;
            local_general += e.general_vertices;
            ++local_paths;
            if (e.dropped) {
              bad = true;
              continue;
            }
            const double w = samples[k].weight;
            E += e.E * w;
            ao += Rgb{e.ao * w};
            if (in.directional) {
              for (int c = 0; c < 4; ++c) sh[c] += e.sh[c] * w;
            }
            weight += w;
          }
          if (bad) dropped.fetch_add(1, std::memory_order_relaxed);
          if (!(weight > 0)) continue;
          const double inv_weight = 1.0 / weight;  // one division for the four channels below
          const Rgb estimate = E * inv_weight;
          if (!LightmapImage::acceptable(estimate)) {
            dropped.fetch_add(1, std::memory_order_relaxed);
            continue;
          }
          p.add(estimate, ao * inv_weight, sh, weight, in.directional);
        }
        if (item.partial < 0) {
          merge(m, t, p);
        } else {
          partials[item.partial] = p;
        }
      }
      rays.fetch_add(local_rays, std::memory_order_relaxed);
      occlusion_rays.fetch_add(local_occlusion, std::memory_order_relaxed);
      paths.fetch_add(local_paths, std::memory_order_relaxed);
      general_vertices.fetch_add(local_general, std::memory_order_relaxed);
    });
    for (const Item& item : items) {
      if (item.partial >= 0) merge(maps[item.map], item.texel, partials[item.partial]);
    }
    check_cancel(control);
    result.rays += rays.load();
    result.occlusion_rays += occlusion_rays.load();
    result.samples += paths.load();
    result.general_vertices += general_vertices.load();
    // The error after this pass, over every valid texel of every lightmap.
    double sum_sq = 0;
    size_t estimated = 0, above = 0, valid = 0;
    std::vector<LightmapImage::ErrorSummary> summaries(maps.size());
    tbb::parallel_for(size_t{0}, maps.size(), [&](size_t mi) {
      summaries[mi] = maps[mi].image.error_summary(in.target_error);
    });
    for (const LightmapImage::ErrorSummary& e : summaries) {
      sum_sq += e.rms * e.rms * static_cast<double>(e.estimated);
      estimated += e.estimated;
      above += e.above_target;
      valid += e.valid;
    }
    const double rms = estimated ? std::sqrt(sum_sq / static_cast<double>(estimated)) : -1;
    const double elapsed = seconds_since(t0);
    result.curve.push_back({elapsed, result.samples, rms});
    const double done = valid ? 1.0 - static_cast<double>(above) / static_cast<double>(valid) : 1.0;
    progress(0.05 + 0.9 * done, "pass " + std::to_string(pass + 1), rms);
    if (out_of_time.load() || Clock::now() >= deadline) break;
  }
  result.error_estimate = result.curve.empty() ? 0 : std::max(0.0, result.curve.back().error);

  // 6. Outputs.
  LightmapOutputOptions out_options;
  out_options.padding = in.padding;
  out_options.color_space = color_space;
  std::ostringstream maps_json;
  for (size_t mi = 0; mi < maps.size(); ++mi) {
    const Lightmap& m = maps[mi];
    for (bake::BakeOutput& o : encode_lightmap(m.image, out_options)) result.outputs.push_back(std::move(o));
    const std::string& name = m.name;
    const LightmapImage& img = m.image;
    if (in.radiance) {
      image::FloatImage rad = texel_image(img, 3, {"R", "G", "B"}, [&](size_t t, float* px) {
        Rgb rho;
        double w = 0;
        const auto samples = m.texels.at(t);
        for (const TexelSample& ts : samples) {
          rho += reflectance(s, materials, ts) * ts.weight;
          w += ts.weight;
        }
        const Rgb L = img.mean(t) * (w > 0 ? rho / w : Rgb{}) / kPi;
        px[0] = static_cast<float>(L.r);
        px[1] = static_cast<float>(L.g);
        px[2] = static_cast<float>(L.b);
      });
      rad.metadata["kiln:content"] = "baked diffuse radiance rho*E/pi, W/(m^2 sr)";
      rad.metadata["kiln:lightmap"] = name;
      result.outputs.push_back({name + "_radiance.exr", "image/x-exr", color_space, image::encode_exr(rad)});
    }
    if (in.ao) {
      image::FloatImage ao = texel_image(img, 1, {"Y"}, [&](size_t t, float* px) {
        px[0] = img.count(t) ? static_cast<float>(m.ao_sum[t].r / img.count(t)) : 0.0f;
      });
      ao.metadata["kiln:content"] = "ambient occlusion: cosine-weighted fraction of rays unoccluded within " +
                                    format_number(ctx.ao_distance);
      ao.metadata["kiln:lightmap"] = name;
      result.outputs.push_back({name + "_ao.exr", "image/x-exr", "data", image::encode_exr(ao)});
    }
    double sh_error_rms = -1, sh_error_max = 0;
    if (in.directional) {
      image::FloatImage sh = texel_image(
          img, 12, {"L00.R", "L00.G", "L00.B", "L1m1.R", "L1m1.G", "L1m1.B", "L10.R", "L10.G", "L10.B", "L11.R",
                    "L11.G", "L11.B"},
          [&](size_t t, float* px) {
            const double n = img.count(t);
            for (int c = 0; c < 4; ++c) {
              for (int k = 0; k < 3; ++k) px[3 * c + k] = n ? static_cast<float>(m.sh_sum[t][c][k] / n) : 0.0f;
            }
          });
      sh.metadata["kiln:content"] =
          "order-1 SH of incoming radiance L(w), world axes: L00 (Y00 = 0.282095), L1m1 (0.488603 y), L10 "
          "(0.488603 z), L11 (0.488603 x)";
      sh.metadata["kiln:lightmap"] = name;
      double sum_sq = 0;
      size_t estimated = 0;
      for (size_t t = 0; t < img.texel_count(); ++t) {
        if (!img.valid(t)) continue;
        const double e = sh_relative_error(m.sh_sum[t], m.sh_y2[t], img.count(t));
        if (!std::isfinite(e)) continue;
        sum_sq += e * e;
        sh_error_max = std::max(sh_error_max, e);
        ++estimated;
      }
      sh_error_rms = estimated ? std::sqrt(sum_sq / static_cast<double>(estimated)) : -1;
      sh.metadata["kiln:error_rms"] = format_number(sh_error_rms);
      sh.metadata["kiln:error"] =
          "estimated relative standard error per texel: of L00, and of the L1 vector relative to sqrt(3) L00, the "
          "larger; RMS over valid texels in kiln:error_rms, also in report.json";
      result.outputs.push_back({name + "_sh.exr", "image/x-exr", color_space, image::encode_exr(sh)});
    }
    if (in.preview) {
      result.outputs.push_back({name + "_preview.png", "image/png", "srgb_display",
                                preview_png(img.irradiance_image(in.padding), img.validity(), color_space, name)});
    }
    const LightmapImage::ErrorSummary e = img.error_summary(in.target_error);
    const LightmapMemory mem = lightmap_memory(m.texels, state_bytes(in));
    maps_json << (mi ? ",\n    " : "") << "{\"name\": " << json_string(name) << ", \"resolution\": " << img.width()
              << ", \"valid_texels\": " << e.valid << ", \"samples_per_texel_point\": "
              << format_number(mem.samples_per_valid_texel) << ", \"error_rms\": " << format_number(e.rms)
              << ", \"error_max\": " << format_number(e.max) << ", \"above_target\": " << e.above_target;
    if (in.directional) {
      maps_json << ", \"sh_error_rms\": " << format_number(sh_error_rms) << ", \"sh_error_max\": "
                << format_number(sh_error_max);
    }
    maps_json
              << ", \"leaks\": {\"moved\": " << m.leaks.moved << ", \"invalidated\": " << m.leaks.invalidated
              << ", \"texels_invalidated\": " << m.leaks.texels_invalidated << "}, \"memory_bytes\": "
              << mem.total_bytes << ", \"memory\": " << json_string(mem.describe()) << "}";
  }
  result.seconds = seconds_since(t0);

  std::ostringstream json;
  json << "{\n  \"baker\": \"" << kLightmapBakerVersion << "\",\n  \"seconds\": " << format_number(result.seconds)
       << ",\n  \"samples\": " << result.samples << ",\n  \"rays\": " << result.rays
       << ",\n  \"occlusion_rays\": " << result.occlusion_rays
       << ",\n  \"general_bsdf_vertices\": " << result.general_vertices
       << ",\n  \"mrays_per_second\": " << format_number(result.rays / std::max(result.seconds, 1e-9) / 1e6)
       << ",\n  \"target_error\": " << format_number(in.target_error)
       << ",\n  \"error_estimate\": " << format_number(result.error_estimate)
       << ",\n  \"dropped_samples\": " << dropped.load() << ",\n  \"color_space\": " << json_string(color_space)
       << ",\n  \"units\": \"irradiance W/m^2\",\n  \"plan\": [";
  for (size_t i = 0; i < plan.decisions.size(); ++i) {
    const plan::Decision& d = plan.decisions[i];
    json << (i ? "," : "") << "\n    {\"effect\": " << json_string(d.effect) << ", \"enabled\": "
         << (d.enabled ? "true" : "false") << ", \"forced\": " << (d.forced ? "true" : "false")
         << ", \"reason\": " << json_string(d.reason) << "}";
  }
  json << "\n  ],\n  \"bounces\": " << plan.bounces << ",\n  \"albedo_max\": " << format_number(plan.albedo_max)
       << ",\n  \"curve\": [";
  for (size_t i = 0; i < result.curve.size(); ++i) {
    json << (i ? ", " : "") << "{\"seconds\": " << format_number(result.curve[i].seconds) << ", \"samples\": "
         << result.curve[i].samples << ", \"error\": " << format_number(result.curve[i].error) << "}";
  }
  json << "],\n  \"lightmaps\": [\n    " << maps_json.str() << "\n  ],\n  \"tracer\": {\"triangles\": "
       << tracer.triangle_count() << ", \"memory_bytes\": " << tracer.memory_bytes() << ", \"bytes_per_triangle\": "
       << format_number(tracer.triangle_count() ? static_cast<double>(tracer.memory_bytes()) / tracer.triangle_count()
                                                : 0.0)
       << "},\n  \"scene_problems\": {\"total\": " << checked.report.total()
       << ", \"listed\": [";
  for (size_t i = 0; i < result.skipped.size(); ++i) json << (i ? ", " : "") << json_string(result.skipped[i]);
  json << "]}\n}\n";
  result.outputs.push_back({"report.json", "application/json", "", json.str()});
  progress(1.0, "done", result.error_estimate);
  return result;
}

}  // namespace kiln::lightmap
