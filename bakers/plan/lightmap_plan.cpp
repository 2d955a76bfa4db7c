#include "bakers/plan/lightmap_plan.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "bakers/bake/number_format.h"
#include "bakers/bake/range_check.h"
#include "bakers/brdf/albedo.h"
#include "bakers/brdf/material.h"
#include "bakers/math/constants.h"
#include "bakers/math/sampling.h"

namespace kiln::plan {
namespace {

using bake::format_number;

constexpr double kBudgetShare = 0.25;  // of the target error, per pruning (see the header)
constexpr int kMuSteps = 16;           // directions at which albedos are evaluated, μ = (i + 0.5)/16
constexpr int kAlbedoSamples = 1024;   // per directional albedo: E to ~1e-3, ample against target/4 ≥ 2.5e-5·...
constexpr int kOverlapSamples = 4096;  // per δ estimate (bounded integrand: standard error ≤ 0.5/√4096 ≈ 0.008)

bool microfacet(brdf::Model m) {
  return m == brdf::Model::ggx || m == brdf::Model::beckmann || m == brdf::Model::cook_torrance;
}

struct TextureStats {
  Rgb max{0.0}, average{0.0};
  bool uniform = true;
};

TextureStats texture_stats(const scene::Texture& t, double tolerance) {
  TextureStats s;
  if (t.texels.empty()) return s;
  Rgb lo = t.texels[0], hi = t.texels[0], sum{0.0};
  for (const Rgb& c : t.texels) {
    lo = {std::min(lo.r, c.r), std::min(lo.g, c.g), std::min(lo.b, c.b)};
    hi = {std::max(hi.r, c.r), std::max(hi.g, c.g), std::max(hi.b, c.b)};
    sum += c;
  }
  s.max = hi;
  s.average = sum / static_cast<double>(t.texels.size());
  // Uniform: every channel spans less than the tolerance relative to its maximum.
  for (int k = 0; k < 3; ++k) {
    if (hi[k] - lo[k] > tolerance * hi[k]) s.uniform = false;
  }
  return s;
}

// δ = ½∫|p_s − p_d| = 1 − ∫min(p_s, p_d), with p_s = f_s cos/E_s and p_d = cos/π; under cosine sampling
// ∫min(p_s, p_d) = E[min(π f_s/E_s, 1)]. Averaged over μ_o with weight 2μ dμ (cosine-weighted outgoing directions)
// and, for anisotropic lobes, over two azimuths.
double lobe_distance(const brdf::Bxdf& lobe, bool anisotropic, double* average_albedo) {
  const int azimuths = anisotropic ? 2 : 1;
  double distance = 0, albedo = 0, weight = 0;
  brdf::AlbedoOptions options;
  options.samples = kAlbedoSamples;
  for (int i = 0; i < kMuSteps; ++i) {
    const double mu = (i + 0.5) / kMuSteps;
    for (int a = 0; a < azimuths; ++a) {
      const double phi = a * kPi / 2;
      const double s = std::sqrt(std::max(0.0, 1 - mu * mu));
      const Vec3 wo{s * std::cos(phi), s * std::sin(phi), mu};
      const double e_s = brdf::directional_albedo(lobe, wo, options).value.average();
      double overlap = 1.0;
      if (e_s > 0) {  // a lobe that reflects nothing has no shape to compare (δ counts 0: it changes nothing)
        brdf::AlbedoOptions o;
        o.samples = kOverlapSamples;
        overlap = brdf::stratified_estimate(o, 7 + i * 2 + a, [&](Point2 u, double, Pcg32&) {
                    const Vec3 wi = sample_cosine_hemisphere(u);
                    const double ratio = kPi * lobe.eval(wo, wi).average() / e_s;
                    return Rgb{std::min(ratio, 1.0)};
                  }).value.r;
      }
      distance += 2 * mu * (1 - overlap);
      albedo += 2 * mu * e_s;
      weight += 2 * mu;
    }
  }
  *average_albedo = albedo / weight;
  return distance / weight;
}

MaterialAnalysis analyse(const scene::SceneMaterial& m, const std::vector<scene::Texture>& textures, double tolerance) {
  MaterialAnalysis a;
  a.name = m.name;
  Rgb tint = m.base_color;
  if (m.base_color_texture && *m.base_color_texture >= 0 && *m.base_color_texture < static_cast<int>(textures.size())) {
    const TextureStats t = texture_stats(textures[*m.base_color_texture], tolerance);
    tint = tint * t.max;
    a.textured = !t.uniform;
  }
  const double w_s = m.bsdf.combine == brdf::Combine::weights ? m.bsdf.specular_weight : 1.0;
  // An invalid spec throws, as brdf::Material's constructor below would.
  if (const auto error = brdf::validate(m.bsdf)) throw *error;
  if (const std::optional<brdf::LambertianForm> form = brdf::lambertian_form(m.bsdf)) {
    // Both lobes Lambertian: the albedo is A + B·tint at every μ, the specular lobe's is its albedo, and a
    // Lambertian lobe is at distance 0 from a Lambertian one. Exact, where the estimates below would spend
    // ~0.1 CPU s per material (every bake plans) to find the same to ~1e-3.
    for (int k = 0; k < 3; ++k) a.albedo_max = std::max(a.albedo_max, form->A[k] + form->B[k] * tint[k]);
    a.specular_albedo = w_s * m.bsdf.specular.albedo.average();
    a.lobe_distance = 0;
    return a;
  }
  const brdf::Material material(m.bsdf);
  const auto specular = brdf::make_bxdf(m.bsdf.specular);
  const brdf::ModelSpec& s = m.bsdf.specular;
  a.anisotropic = (microfacet(s.model) && s.alpha_x != s.alpha_y) ||
                  ((s.model == brdf::Model::schlick || s.model == brdf::Model::schlick_double) && s.layer.p != 1.0);

  // ρ(μ) = w_s E_s(μ) + tint (E(μ) − w_s E_s(μ)): the diffuse part of the material is linear in the base colour.
  brdf::AlbedoOptions options;
  options.samples = kAlbedoSamples;
  for (int i = 0; i < kMuSteps; ++i) {
    const double mu = (i + 0.5) / kMuSteps;
    const Rgb e = brdf::directional_albedo(material, mu, options).value;
    const Rgb e_s = brdf::directional_albedo(*specular, mu, options).value * w_s;
    for (int k = 0; k < 3; ++k) a.albedo_max = std::max(a.albedo_max, e_s[k] + tint[k] * (e[k] - e_s[k]));
  }
  double e_avg = 0;
  a.lobe_distance = lobe_distance(*specular, a.anisotropic, &e_avg);
  a.specular_albedo = w_s * e_avg;
  return a;
}

bool has_power(const scene::Light& l) {
  if (!(l.color.max() > 0)) return false;
  if (l.type == scene::LightShape::rect) return length(cross(l.u_axis, l.v_axis)) > 0;
  if (l.type == scene::LightShape::disk) return l.radius > 0;
  return true;
}

std::string count_of(int n, const char* what) { return std::to_string(n) + " " + what + (n == 1 ? "" : "s"); }

struct SceneFacts {
  std::array<int, 5> lights{};  // with non-zero power, by LightShape
  int sun_discs = 0;            // directional lights with an angular diameter
  int emissive_triangles = 0;
  std::vector<bool> used;        // per material
  std::vector<int> triangles;    // per material
  double env_max_over_mean = 1;  // of the environment image's luminance

  int count(scene::LightShape shape) const { return lights[static_cast<int>(shape)]; }
  int area_lights() const { return count(scene::LightShape::rect) + count(scene::LightShape::disk); }
};

// Which materials the instances' triangles use, and how many triangles each.
void count_material_use(const scene::Scene& scene, SceneFacts& f) {
  const size_t n_materials = std::max<size_t>(scene.materials.size(), 1);
  f.used.assign(n_materials, false);
  f.triangles.assign(n_materials, 0);
  for (const scene::Instance& inst : scene.instances) {
    if (inst.mesh < 0 || inst.mesh >= static_cast<int>(scene.meshes.size())) continue;
    const scene::Mesh& mesh = scene.meshes[inst.mesh];
    const size_t n = mesh.indices.size() / 3;
    for (size_t t = 0; t < n; ++t) {
      size_t m = mesh.material.empty() ? 0 : mesh.material[std::min(t, mesh.material.size() - 1)];
      if (m >= n_materials) m = 0;  // out of range: material 0, as scene validation reports
      f.used[m] = true;
      ++f.triangles[m];
    }
  }
}

// The brightest texel of the environment image over its solid-angle weighted mean luminance (rows weighted by
// sin θ); 1 for a constant environment, none, or a black image (nothing to importance-sample).
double env_max_over_mean(const scene::Environment& env) {
  if (env.constant || env.equirect.empty()) return 1;
  double sum = 0, weight = 0, peak = 0;
  for (int y = 0; y < env.height; ++y) {
    const double w = std::sin(kPi * (y + 0.5) / env.height);
    for (int x = 0; x < env.width; ++x) {
      const double l = luminance(env.equirect[static_cast<size_t>(y) * env.width + x]);
      sum += w * l;
      weight += w;
      peak = std::max(peak, l);
    }
  }
  const double mean = weight > 0 ? sum / weight : 0;
  return mean > 0 ? peak / mean : 1;
}

SceneFacts gather(const scene::Scene& scene) {
  SceneFacts f;
  for (const scene::Light& l : scene.lights) {
    if (!has_power(l)) continue;
    ++f.lights[static_cast<int>(l.type)];
    if (l.type == scene::LightShape::directional && l.angular_diameter > 0) ++f.sun_discs;
  }
  count_material_use(scene, f);
  for (size_t m = 0; m < scene.materials.size(); ++m) {
    if (scene.materials[m].emission.max() > 0) f.emissive_triangles += f.triangles[m];
  }
  f.env_max_over_mean = env_max_over_mean(scene.environment);
  return f;
}

void check_options(const LightmapPlanOptions& o) {
  if (auto e = bake::check_range("target_error", o.target_error, bounds::kLightmapTargetError)) throw *e;
  if (auto e = bake::check_range("max_bounces", o.max_bounces, bounds::kMaxBounces.real())) throw *e;
  if (auto e = check_forced_names(o.force_effects, lightmap_effect_names())) throw *e;
}

// The flags of the plan from its decisions.
void apply(LightmapPlan& p) {
  using E = LightmapEffect;
  p.point_lights = p.enabled(E::point_lights);
  p.spot_lights = p.enabled(E::spot_lights);
  p.directional_lights = p.enabled(E::directional_lights);
  p.area_lights = p.enabled(E::area_lights);
  p.emissive_triangles = p.enabled(E::emissive_triangles);
  p.environment_sampling = p.enabled(E::environment_sampling);
  p.environment_importance_map = p.environment_sampling && p.enabled(E::environment_importance_map);
  p.multiple_importance_sampling = p.enabled(E::multiple_importance_sampling);
  if (!p.enabled(E::indirect_bounces)) p.bounces = 0;
  p.specular_interreflection = p.bounces > 0 && p.enabled(E::specular_interreflection);
  p.anisotropy = p.enabled(E::anisotropy);
  p.textures = p.enabled(E::textures);
  p.russian_roulette = p.enabled(E::russian_roulette) && p.bounces > p.russian_roulette_depth;
  p.light_tracing = p.enabled(E::light_tracing) && p.bounces > 0;
}

// What the stages of plan_lightmap share. Each stage appends its effects' decisions, in the order of
// lightmap_effects().
struct Planning {
  const scene::Scene& scene;
  const LightmapPlanOptions& options;
  const double budget;  // of bias, per pruning
  const SceneFacts facts;
  LightmapPlan plan;
  // Participating media, decided before the bounces (their albedo counts) and light tracing (which they rule out),
  // recorded after it (the decisions follow lightmap_effects()).
  MediaMode media_planned = MediaMode::none;
  std::string media_reason, scattering_reason;

  void decide(LightmapEffect effect, bool planned, const std::string& reason) {
    plan.decisions.push_back(kiln::plan::decide(effect_name(effect), planned, reason, options.force_effects));
  }
  bool has_environment() const {
    const scene::Environment& env = scene.environment;
    return env.constant ? env.constant->max() > 0 : !env.equirect.empty();
  }
};

void analyse_materials(Planning& s) {
  for (size_t m = 0; m < s.scene.materials.size(); ++m) {
    MaterialAnalysis a = analyse(s.scene.materials[m], s.scene.textures, s.budget);
    a.used = s.facts.used[m];
    a.glossy = a.used && 2 * a.specular_albedo * a.lobe_distance > s.budget;
    if (a.used) s.plan.albedo_max = std::max(s.plan.albedo_max, a.albedo_max);
    s.plan.materials.push_back(a);
  }
}

// One strategy per kind of light the scene has.
void decide_lights(Planning& s) {
  auto lights = [&](LightmapEffect effect, scene::LightShape shape, const char* what) {
    const int n = s.facts.count(shape);
    s.decide(effect, n > 0,
             n > 0 ? "the scene has " + count_of(n, what) + " with non-zero power"
                   : std::string("the scene has no ") + what + " with non-zero power");
  };
  lights(LightmapEffect::point_lights, scene::LightShape::point, "point light");
  lights(LightmapEffect::spot_lights, scene::LightShape::spot, "spot light");
  lights(LightmapEffect::directional_lights, scene::LightShape::directional, "directional light");
  const int area = s.facts.area_lights();
  s.decide(LightmapEffect::area_lights, area > 0,
           area > 0 ? "the scene has " + count_of(area, "rectangle or disk light")
                    : "the scene has no rectangle or disk light with non-zero power");
  const int emissive = s.facts.emissive_triangles;
  s.decide(LightmapEffect::emissive_triangles, emissive > 0,
           emissive > 0 ? count_of(emissive, "triangle") + " of emissive materials" : "no material emits light");
}

void decide_environment(Planning& s) {
  const scene::Environment& env = s.scene.environment;
  const bool has_env = s.has_environment();
  s.decide(LightmapEffect::environment_sampling, has_env,
           has_env
               ? (env.constant ? "a constant environment " + bake::format_rgb(*env.constant)
                               : "an environment image " + std::to_string(env.width) + "x" + std::to_string(env.height))
               : "no environment (or a black one)");
  bool want = false;
  std::string why;
  if (!has_env) {
    why = "no environment";
  } else if (env.constant) {
    why = "a constant environment: cosine sampling already has zero variance for irradiance";
  } else if (s.facts.env_max_over_mean <= 2) {
    why = "the brightest texel is " + format_number(s.facts.env_max_over_mean) +
          " x the mean radiance (<= 2): importance weights would vary by at most 2 x, cosine sampling suffices";
  } else {
    want = true;
    why = "the brightest texel is " + format_number(s.facts.env_max_over_mean) + " x the mean radiance";
  }
  s.decide(LightmapEffect::environment_importance_map, want, why);
}

// MIS pays only where a sampled ray can hit a light.
void decide_mis(Planning& s) {
  const int hittable =
      s.facts.area_lights() + s.facts.emissive_triangles + s.facts.sun_discs + (s.has_environment() ? 1 : 0);
  s.decide(LightmapEffect::multiple_importance_sampling, hittable > 0,
           hittable > 0 ? "some lights can be hit by sampled rays (area, emissive, sun disc or "
                          "environment): light and cosine sampling are combined"
                        : "only delta lights (points, spots, delta suns): light sampling alone");
}

// The share of the light a scattering medium carries into each further scattering, as the planner estimates it: the
// single-scattering albedo times what the media take from typical light paths (upper end: + 2 standard errors).
double media_albedo(const Planning& s) {
  if (s.plan.media_mode != MediaMode::scattering) return 0;
  const MediaAnalysis& a = s.plan.media_analysis;
  return a.albedo * std::min(1.0, a.extinction + 2 * a.extinction_error);
}

// The smallest k with ρ^(k+1) ≤ budget, ρ the larger of ρ_max and the media's share per scattering.
void decide_bounces(Planning& s) {
  LightmapPlan& p = s.plan;
  const int max_bounces = s.options.max_bounces;
  std::string why;
  const double rho = std::max(p.albedo_max, media_albedo(s));
  if (!(rho > 0)) {
    p.bounces = 0;
    why = "no used material reflects light (rho_max = 0)";
  } else if (rho >= 1) {
    p.bounces = max_bounces;
    why = "rho_max = " + format_number(rho) + " >= 1: light does not decay; capped at " + std::to_string(max_bounces) +
          " bounces";
  } else {
    const int needed = std::max(0, static_cast<int>(std::ceil(std::log(s.budget) / std::log(rho))) - 1);
    p.bounces = std::min(needed, max_bounces);
    why = "rho_max = " + format_number(rho) + ": " + std::to_string(p.bounces) + " bounces leave at most rho^" +
          std::to_string(p.bounces + 1) + " = " + format_number(std::pow(rho, p.bounces + 1)) +
          " of the light unsimulated (budget " + format_number(s.budget) + " = target/4)";
    if (needed > max_bounces) why += "; capped by max_bounces, above the budget";
  }
  if (media_albedo(s) > p.albedo_max) why += " (rho: the media's scattering albedo x the light they take)";
  s.decide(LightmapEffect::indirect_bounces, p.bounces > 0, why);
}

// ---- Participating media ----

// The value an effect will have: the job's forcing, else the planner's.
bool final_value(const Planning& s, LightmapEffect effect, bool planned) {
  const auto it = s.options.force_effects.find(effect_name(effect));
  return it == s.options.force_effects.end() ? planned : it->second;
}

// Two significant digits: estimates from a few hundred paths, for people.
std::string rounded(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.2g", v);
  return text;
}

// What the media take from typical light paths, for people.
std::string taken(const MediaAnalysis& a) {
  return "the media take " + rounded(a.extinction) + " +- " + rounded(a.extinction_error) + " of the light along " +
         std::to_string(a.paths) + " sampled light paths";
}

// The planner's mode and its reasons: skipped where they take less than the budget from typical light paths,
// attenuation only where what they scatter (albedo × that) is below it, in full otherwise; emitting media in full.
void plan_media_mode(Planning& s, const MediaAnalysis& a) {
  std::string skipped;
  for (const std::string& why : a.skipped) skipped += "; " + why;
  const double budget = s.budget, ext = std::min(1.0, a.extinction + 2 * a.extinction_error);
  if (a.active.empty()) {
    s.media_reason = (s.options.media.empty() ? "no participating media" : "no medium touches the scene") + skipped;
    s.scattering_reason = "no media simulated";
    return;
  }
  if (!a.emissive && ext <= budget) {
    s.media_reason = taken(a) + " (at most " + rounded(ext) + " <= the budget " + format_number(budget) +
                     " = target/4): skipped" + skipped;
    s.scattering_reason = "no media simulated";
    return;
  }
  s.media_planned = MediaMode::attenuation;
  s.media_reason = taken(a) + (a.emissive ? "; some medium emits" : "") + skipped;
  const double scattered = a.albedo * ext;
  if (!a.emissive && scattered <= budget) {
    s.scattering_reason = "they scatter at most " + rounded(scattered) + " (albedo " + rounded(a.albedo) + " x " +
                          rounded(ext) + ", <= the budget " + format_number(budget) +
                          "): attenuation only, every ray's transmittance without in-scattering";
    return;
  }
  s.media_planned = MediaMode::scattering;
  s.scattering_reason = a.emissive ? "some medium emits: free flights collect its emission and scatter"
                                   : "they scatter " + rounded(scattered) + " (albedo " + rounded(a.albedo) + " x " +
                                         rounded(ext) + ") of the light";
}

void plan_media(Planning& s) {
  if (!s.options.media.empty()) {
    s.plan.media_analysis = analyse_media(s.scene, *s.options.media_inputs, s.options.media);
  }
  const MediaAnalysis& a = s.plan.media_analysis;
  plan_media_mode(s, a);
  using E = LightmapEffect;
  const bool on = final_value(s, E::participating_media, s.media_planned != MediaMode::none);
  const bool scatter = final_value(s, E::media_scattering, s.media_planned == MediaMode::scattering);
  // Forced on, there must be a medium to simulate: media outside the scene stay skipped.
  s.plan.media_mode = a.active.empty() || !on ? MediaMode::none
                      : scatter               ? MediaMode::scattering
                                              : MediaMode::attenuation;
  if (s.plan.media_mode != MediaMode::none) s.plan.media = a.active_index;
}

void decide_media(Planning& s) {
  s.decide(LightmapEffect::participating_media, s.media_planned != MediaMode::none, s.media_reason);
  s.decide(LightmapEffect::media_scattering, s.media_planned == MediaMode::scattering, s.scattering_reason);
}

void decide_specular(Planning& s) {
  int glossy = 0, used = 0;
  std::string worst;
  double worst_impact = -1;
  for (const MaterialAnalysis& a : s.plan.materials) {
    if (!a.used) continue;
    ++used;
    glossy += a.glossy;
    const double impact = 2 * a.specular_albedo * a.lobe_distance;
    if (impact > worst_impact) {
      worst_impact = impact;
      worst = a.name + " (2 E_s delta = " + format_number(impact) + ")";
    }
  }
  std::string why = std::to_string(glossy) + " of " + std::to_string(used) +
                    " used materials have a specular lobe that changes reflected light by more than the budget " +
                    format_number(s.budget);
  if (used) why += "; the largest: " + worst;
  if (s.plan.bounces == 0) why = "no bounces: no material's lobe affects irradiance";
  s.decide(LightmapEffect::specular_interreflection, s.plan.bounces > 0 && glossy > 0, why);
}

void decide_anisotropy(Planning& s) {
  int n = 0;
  for (const MaterialAnalysis& a : s.plan.materials) n += a.used && a.glossy && a.anisotropic;
  s.decide(
      LightmapEffect::anisotropy, n > 0 && s.plan.bounces > 0,
      n > 0 ? count_of(n, "glossy material") + " with anisotropic lobes" : "no simulated specular lobe is anisotropic");
}

void decide_textures(Planning& s) {
  int n = 0;
  for (const MaterialAnalysis& a : s.plan.materials) n += a.used && a.textured;
  std::string why = n > 0 ? count_of(n, "used material") + " with a non-uniform base-colour texture"
                          : "no used material has a non-uniform base-colour texture";
  if (n > 0 && s.plan.bounces == 0) why = "no bounces: base colours do not affect irradiance";
  s.decide(LightmapEffect::textures, n > 0 && s.plan.bounces > 0, why);
}

void decide_russian_roulette(Planning& s) {
  const int depth = s.plan.russian_roulette_depth;
  const bool want = s.plan.bounces > depth;
  s.decide(LightmapEffect::russian_roulette, want,
           want ? "paths beyond " + std::to_string(depth) +
                      " bounces continue with the probability of their throughput (unbiased)"
                : "at most " + std::to_string(depth) + " bounces");
}

// Why light tracing cannot serve the bake (empty: it can). Rays start at lights with a position; light from
// infinitely far (the environment, directional lights) is gathered, and so is everything when an output needs it.
std::string light_tracing_obstacle(const Planning& s) {
  if (s.options.directional) {
    return "the directional (SH) output needs the direction of all the light each path gathers";
  }
  if (s.has_environment() || s.facts.count(scene::LightShape::directional) > 0) {
    return "light from infinitely far (the environment or a directional light) cannot be traced from its source";
  }
  if (s.options.per_texel_error) {
    return "the texel error metric asks every texel, however dark, for the same relative error, which rays from the "
           "lights cannot aim at";
  }
  if (s.plan.media_mode != MediaMode::none) {
    return "the scene has participating media, which rays from the lights are not tracked through (only gathered "
           "paths sample them)";
  }
  if (s.options.tiled) {
    return "the bake is tiled to fit its memory limit, and rays from the lights deposit into every texel of every "
           "page, whose sums (128 bytes a texel) it would have to hold all at once";
  }
  return "";
}

void decide_light_tracing(Planning& s) {
  const std::string obstacle = light_tracing_obstacle(s);
  const int lights = s.facts.count(scene::LightShape::point) + s.facts.count(scene::LightShape::spot) +
                     s.facts.area_lights() + (s.facts.emissive_triangles > 0 ? 1 : 0);
  std::string why;
  if (s.plan.bounces == 0) {
    why = "no bounces: texels gather their direct light";
  } else if (!obstacle.empty()) {
    why = obstacle + ": every texel gathers all its light";
  } else if (lights == 0) {
    why = "no light with a position has power";
  } else {
    why = "indirect light (" + std::to_string(s.plan.bounces) +
          " bounces) by rays traced from the lights, each serving every texel it reaches; texels gather their "
          "direct light (those with shading normals or moved sample points gather all)";
  }
  s.decide(LightmapEffect::light_tracing, s.plan.bounces > 0 && obstacle.empty() && lights > 0, why);
  const auto forced = s.options.force_effects.find(effect_name(LightmapEffect::light_tracing));
  if (forced != s.options.force_effects.end() && forced->second && !obstacle.empty()) {
    throw bake::InvalidInput("force_effects", "light_tracing cannot be forced on for this bake: " + obstacle +
                                                  "; leave it to the planner or force it off");
  }
}

// What a job's forcing implies beyond its decisions.
void follow_forced(Planning& s) {
  LightmapPlan& p = s.plan;
  // A forced bounce count: forcing indirect_bounces on when the planner chose 0 simulates the cap.
  if (p.enabled(LightmapEffect::indirect_bounces) && p.bounces == 0) p.bounces = std::max(1, s.options.max_bounces);
  // Materials follow a forced specular_interreflection.
  const auto& forced = s.options.force_effects;
  if (auto it = forced.find(effect_name(LightmapEffect::specular_interreflection)); it != forced.end()) {
    for (MaterialAnalysis& a : p.materials) a.glossy = it->second && a.used && a.specular_albedo > 0;
  }
}

// Light strategies stay as the scene has them in a full plan: a light that is absent cannot be sampled.
bool follows_the_scene(LightmapEffect effect) {
  using E = LightmapEffect;
  return effect == E::point_lights || effect == E::spot_lights || effect == E::directional_lights ||
         effect == E::area_lights || effect == E::emissive_triangles || effect == E::environment_sampling;
}

}  // namespace

const char* to_string(MediaMode mode) {
  switch (mode) {
    case MediaMode::none:
      return "none";
    case MediaMode::attenuation:
      return "attenuation";
    case MediaMode::scattering:
      return "scattering";
  }
  return "none";
}

bool LightmapPlan::enabled(LightmapEffect effect) const { return enabled(effect_name(effect)); }

bool LightmapPlan::enabled(const std::string& effect) const {
  for (const Decision& d : decisions) {
    if (d.effect == effect) return d.enabled;
  }
  return false;
}

LightmapPlan plan_lightmap(const scene::Scene& scene, const LightmapPlanOptions& options) {
  check_options(options);
  const double budget = kBudgetShare * options.target_error;
  Planning s{scene, options, budget, gather(scene), {}};
  analyse_materials(s);
  plan_media(s);
  decide_lights(s);
  decide_environment(s);
  decide_mis(s);
  decide_bounces(s);
  decide_specular(s);
  decide_anisotropy(s);
  decide_textures(s);
  decide_russian_roulette(s);
  decide_light_tracing(s);
  decide_media(s);
  follow_forced(s);
  apply(s.plan);
  return std::move(s.plan);
}

LightmapPlan full_plan(const scene::Scene& scene, const LightmapPlanOptions& options) {
  LightmapPlanOptions o = options;
  o.force_effects.clear();
  check_options(o);
  LightmapPlan planned = plan_lightmap(scene, o);
  LightmapPlan p = planned;
  p.bounces = options.max_bounces;
  for (Decision& d : p.decisions) {
    const LightmapEffect effect = *parse_lightmap_effect(d.effect);
    if (follows_the_scene(effect)) continue;
    // Light tracing is a way to simulate, not an effect: the reference gathers everything. Media: all that touch
    // the scene, in full.
    d.enabled = effect == LightmapEffect::participating_media || effect == LightmapEffect::media_scattering
                    ? !planned.media_analysis.active.empty()
                    : effect != LightmapEffect::light_tracing;
    d.reason = d.enabled ? "full simulation: everything on" : "full simulation: every texel gathers all its light";
  }
  if (!p.environment_sampling || scene.environment.constant) {  // no image: nothing to build a map of
    for (Decision& d : p.decisions) {
      if (d.effect == effect_name(LightmapEffect::environment_importance_map)) d.enabled = false;
    }
  }
  for (MaterialAnalysis& a : p.materials) a.glossy = a.used && a.specular_albedo > 0;
  p.media_mode = planned.media_analysis.active.empty() ? MediaMode::none : MediaMode::scattering;
  p.media = planned.media_analysis.active_index;
  apply(p);
  p.russian_roulette = p.bounces > p.russian_roulette_depth;
  return p;
}

}  // namespace kiln::plan
