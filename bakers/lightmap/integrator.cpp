#include "bakers/lightmap/integrator.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "bakers/envmap/sh.h"
#include "bakers/lightmap/path_sampler.h"
#include "bakers/lightmap/ray_log.h"
#include "bakers/math/constants.h"
#include "bakers/math/sampling.h"
#include "bakers/scene/emissive_triangles.h"
#include "bakers/scene/light_sampler.h"
#include "bakers/scene/ray_offset.h"
#include "bakers/scene/texture_sample.h"
#include "bakers/scene/tracer.h"
#include "bakers/volume/medium.h"
#include "bakers/volume/phase_mixture.h"
#include "bakers/volume/tracking.h"

namespace kiln::lightmap {
namespace {

using scene::kInfinity;

// All three channels finite, by one test of their sum: a NaN or infinite channel makes it NaN or infinite (so does a
// sum past DBL_MAX, ~1e308, which no radiance or path weight comes near: such a value is as unusable).
bool finite(const Rgb& c) { return std::isfinite(c.r + c.g + c.b); }

// Real orthonormal SH of order 1 in world coordinates: Y00, Y1−1 ∝ y, Y10 ∝ z, Y11 ∝ x.
void add_sh(Rgb sh[4], const Vec3& w, const Rgb& value) {
  constexpr double c0 = 0.28209479177387814, c1 = 0.4886025119029199;
  sh[0] += value * c0;
  sh[1] += value * (c1 * w.y);
  sh[2] += value * (c1 * w.z);
  sh[3] += value * (c1 * w.x);
}

// Real orthonormal SH of order 2 (ProbeEstimate): envmap's basis, whose first four are add_sh's.
void add_sh9(Rgb sh[9], const Vec3& w, const Rgb& value) {
  const envmap::ShBasis Y = envmap::sh_basis(w);
  for (int k = 0; k < 9; ++k) sh[k] += value * Y[k];
}

// The balance heuristic for a sample of density `a` against the other strategy's density `b`.
double balance(double a, double b) { return a > 0 ? a / (a + b) : 0.0; }

// The last ray of a path through media: where it left from, the normal its direction's MIS weights are taken about
// (a surface's shading normal; at a scattering point, the direction of travel), its direction's density.
struct Segment {
  scene::Ray ray;
  Vec3 n;
  double pdf = 0;
};

// kMedia: the scene has participating media (ctx.medium); without, the walk is the surface walk alone.
template <bool kMedia>
struct Walk {
  const TransportContext& ctx;
  PathSampler& sampler;
  IrradianceEstimate& out;

  // A closest-hit query into `hit` (untouched on a miss); true on a hit.
  bool trace(const scene::Ray& ray, scene::Hit& hit) {
    ++out.rays;
    if (ctx.ray_log) ctx.ray_log->record(ray, RayKind::closest);
    return ctx.tracer->intersect(ray, hit, scene::HitDetail{.lightmap_uv = false, .uv = ctx.textured});
  }
  bool visible(const scene::Ray& ray) {
    ++out.rays;
    ++out.occlusion_rays;
    if (ctx.ray_log) ctx.ray_log->record(ray, RayKind::occlusion);
    return !ctx.tracer->occluded(ray);
  }

  // Weight of a cosine- or BSDF-sampled direction (density `pdf`) that reached light `index`: light sampling would
  // have drawn it with pmf·pdf_li. A light the plan does not light-sample (pmf 0) is found by this strategy alone.
  double mis_weight(double pdf, int index, const Vec3& p, const Vec3& n, const Vec3& wi, const scene::LightHit& hit) {
    const double pmf = ctx.lights->pmf(index);
    if (pmf <= 0) return 1.0;
    const scene::LightSource& light = ctx.lights->light(index);
    // Light sampling alone owns the sampled lights without MIS, and those it samples uniformly in solid angle (a
    // skewed estimator otherwise: measured 4 % low texels at a 1 % target under a small rectangle light).
    if (!ctx.plan->multiple_importance_sampling || light.uniform_in_solid_angle(p)) return 0.0;
    return balance(pdf, pmf * light.pdf_li(p, n, wi, hit));
  }

  // Adds to L, times beta, the radiance reaching `p` along `wi` from the analytic area lights the ray passes before
  // t_hit (they are not scene geometry: they neither occlude nor end a path) and, for an escaping ray, from the
  // infinite lights.
  [[gnu::always_inline]] void add_lights_along(Rgb& L, const Rgb& beta, const Vec3& p, const Vec3& n, const Vec3& wi,
                                               double t_hit, double pdf, bool escaped) {
    if (!ctx.has_analytic_lights && !escaped) return;  // the common case: geometry hit, nothing between
    L += beta * any_lights_along(p, n, wi, t_hit, pdf, escaped);
  }
  Rgb any_lights_along(const Vec3& p, const Vec3& n, const Vec3& wi, double t_hit, double pdf, bool escaped) {
    Rgb L;
    for (int index : ctx.analytic_lights) {
      const scene::LightSource& light = ctx.lights->light(index);
      if (auto h = light.intersect(p, wi, t_hit)) L += light.Le(p, wi, *h) * mis_weight(pdf, index, p, n, wi, *h);
    }
    if (escaped) L += escaped_radiance(p, n, wi, pdf);
    return L;
  }
  // The radiance of the infinite lights along an escaping ray, MIS-weighted.
  Rgb escaped_radiance(const Vec3& p, const Vec3& n, const Vec3& wi, double pdf) {
    Rgb L;
    for (int index : ctx.lights->escape_lights()) {
      const scene::LightHit h;
      const scene::LightSource& light = ctx.lights->light(index);
      L += light.Le(p, wi, h) * mis_weight(pdf, index, p, n, wi, h);
    }
    return L;
  }

  const ShadingMaterial& material(const scene::Hit& hit) const { return (*ctx.materials)[hit.material]; }

  // Adds to L, times beta, the emission of the surface at `hit` seen from `p` along wi, weighted against light
  // sampling of the emissive triangles.
  [[gnu::always_inline]] void add_emitted(Rgb& L, const Rgb& beta, const scene::Hit& hit, const Vec3& p, const Vec3& n,
                                          const Vec3& wi, double pdf) {
    const ShadingMaterial& m = material(hit);
    if (!m.emissive || !(hit.front_face || m.two_sided)) return;  // the common case: it does not emit
    L += beta * emitted(m, hit, p, n, wi, pdf);
  }
  Rgb emitted(const ShadingMaterial& m, const scene::Hit& hit, const Vec3& p, const Vec3& n, const Vec3& wi,
              double pdf) {
    double w = 1.0;
    if (ctx.emissive_light >= 0) {
      scene::LightHit lh;
      lh.point = hit.p;
      lh.normal = hit.ng;
      lh.distance = hit.t;
      lh.triangle = ctx.lights->emissive()->find(hit.instance, hit.triangle);
      if (lh.triangle >= 0) w = mis_weight(pdf, ctx.emissive_light, p, n, wi, lh);
    }
    return m.emission * w;
  }

  Rgb tint(const ShadingMaterial& m, const scene::Hit& hit) const {
    if (m.texture < 0) return m.base_color * m.texture_average;
    return m.base_color * scene::sample_bilinear(ctx.scene->textures[m.texture], hit.uv);
  }

  // Next-event estimation from surface point `from` (path vertex `vertex`) with shading normal ns: one light by
  // power, one point on it.
  // `f_cos(wi)` is the reflectance times cos θ for a world direction, `pdf_other(wi)` the density the other strategy
  // would have drawn it with. Returns f·Li·w/p; `radiance` receives Li·w/p for the SH (receiver only).
  template <class F, class Pdf>
  Rgb next_event(int vertex, const scene::SurfacePoint& from, const Vec3& ns, F&& f_cos, Pdf&& pdf_other,
                 Rgb* radiance = nullptr, Vec3* direction = nullptr) {
    // A single light is chosen whatever the number: none is drawn for it.
    const auto choice = ctx.lights->sample(ctx.lights->single() ? 0.0 : sampler.light_choice(vertex));
    if (!choice) return Rgb{};
    const Point2 u = sampler.light_point(vertex);
    // The emissive triangles directly, inlined, so that their sample stays in registers; the other lights through
    // the interface (whose sample comes back through memory).
    if (choice->index == ctx.emissive_light) {
      const auto s = ctx.lights->emissive()->sample(from.p, u);
      return s ? shade_light_sample(*s, *choice, from, f_cos, pdf_other, radiance, direction) : Rgb{};
    }
    const auto s = choice->light->sample_li(from.p, ns, u);
    return s ? shade_light_sample(*s, *choice, from, f_cos, pdf_other, radiance, direction) : Rgb{};
  }

  // The rest of next-event estimation for light sample `s` of `choice`: its shadow ray and its weight.
  template <class F, class Pdf>
  [[gnu::always_inline]] Rgb shade_light_sample(const scene::LightSample& s, const scene::SceneLights::Choice& choice,
                                                const scene::SurfacePoint& from, F&& f_cos, Pdf&& pdf_other,
                                                Rgb* radiance, Vec3* direction) {
    if (!(s.Li.max() > 0)) return Rgb{};
    // Below the geometric surface the ray would start inside the geometry: no light arrives from there.
    if (dot(s.wi, from.ng) <= 0) return Rgb{};
    const Rgb fc = f_cos(s.wi);
    if (!(fc.max() > 0)) return Rgb{};
    // On ng's side (tested above): the rays leave from the front.
    const scene::Ray ray =
        std::isfinite(s.distance) ? scene::spawn_ray_to_front(from, s.point) : scene::spawn_ray_front(from, s.wi);
    if (!visible(ray)) return Rgb{};
    Rgb Li = s.Li;
    if constexpr (kMedia) {
      Li = Li * transmittance(ray);
      if (!(Li.max() > 0)) return Rgb{};
    }
    double weight;
    if (s.delta) {
      weight = 1.0 / choice.pmf;
    } else {
      const double p_light = choice.pmf * s.pdf;
      if (!(p_light > 0)) return Rgb{};
      // The balance heuristic's weight over the density, w/p = (p/(p + p_other))/p = 1/(p + p_other).
      weight = ctx.plan->multiple_importance_sampling && !choice.light->uniform_in_solid_angle(from.p)
                   ? 1.0 / (p_light + pdf_other(s.wi))
                   : 1.0 / p_light;
    }
    if (radiance) {
      *radiance = Li * weight;
      *direction = s.wi;
    }
    return fc * Li * weight;
  }

  // Radiance leaving *hit towards wo (world), reflected there at least once: path tracing with next-event
  // estimation; `depth` counts the reflections of the light arriving at the receiver. The two records take turns
  // as the vertex shaded and the next one found (swapped, never copied; a Hit is ~170 bytes).
  // With media, `beta` and `first_depth` carry the path's throughput and reflections on arriving at *hit_record.
  Rgb reflected(scene::Hit* hit_record, scene::Hit* next_record, Vec3 wo, Rgb beta = Rgb{1.0}, int first_depth = 1) {
    Rgb L;
    const plan::LightmapPlan& plan = *ctx.plan;
    for (int depth = first_depth;; ++depth) {
      const scene::Hit& hit = *hit_record;
      scene::Hit& next = *next_record;
      const ShadingMaterial& m = material(hit);
      // Reflect on whichever side the ray arrived (one-sided geometry seen from behind still reflects). wo is the
      // reversed direction of the ray that found the hit, so the tracer's front_face says which side it is on.
      scene::SurfacePoint surface = hit.surface();
      Vec3 ns = hit.ns;
      if (!hit.front_face) {
        surface.ng = -surface.ng;
        ns = -ns;
      }
      const Frame frame = Frame::from_normal(ns);
      // Below the shading normal's horizon (cos θo = frame.to_local(wo).z ≤ 0): no reflection is defined there.
      if (dot(wo, frame.n) <= 0) break;
      Vec3 wi;
      double pdf_wi;
      if (m.lambertian) {
        // Closed form: f = ρ/π with ρ = A + B·tint (precomputed without a texture); cosine sampling, so
        // f cos θ / pdf = ρ.
        const Rgb rho = m.texture < 0 ? m.rho : m.lambertian->A + m.lambertian->B * tint(m, hit);
        auto f_cos = [&](const Vec3& w) { return rho * (std::max(0.0, dot(w, ns)) * kInvPi); };
        auto pdf = [&](const Vec3& w) { return std::max(0.0, dot(w, ns)) * kInvPi; };
        L += beta * next_event(depth, surface, ns, f_cos, pdf);
        const Vec3 local = sampler.cosine_direction(depth);
        if (!(local.z > 0)) break;  // on the rim of the hemisphere: cos θ = 0 reflects nothing
        wi = frame.from_local(local);
        pdf_wi = local.z * kInvPi;
        beta = beta * rho;  // finite as ρ is: a non-finite texel is caught with the estimate (estimate_irradiance)
      } else {
        ++out.general_vertices;
        const Rgb t = tint(m, hit);
        const Vec3 wo_local = frame.to_local(wo);
        auto f_cos = [&](const Vec3& w) {
          const Vec3 wi_local = frame.to_local(w);
          return m.bsdf->eval(wo_local, wi_local, t) * std::abs(wi_local.z);
        };
        auto pdf = [&](const Vec3& w) { return m.bsdf->pdf(wo_local, frame.to_local(w)); };
        L += beta * next_event(depth, surface, ns, f_cos, pdf);
        const std::optional<brdf::BsdfSample> s =
            m.bsdf->sample(wo_local, sampler.direction(depth), sampler.lobe(depth), t);
        if (!s) break;
        wi = frame.from_local(s->wi);
        pdf_wi = s->pdf;
        beta = beta * s->weight;
        if (!finite(beta)) break;  // a sampled weight f·cos/pdf that overflowed
      }
      if (dot(wi, surface.ng) <= 0) break;  // into the surface (the shading normal disagrees with the geometry)
      if (!(beta.max() > 0)) break;         // nothing more can reach the receiver
      const scene::Ray ray = scene::spawn_ray_front(surface, wi);  // dot(wi, ng) > 0, tested above
      const bool found = trace(ray, next);
      if constexpr (kMedia) {
        Segment segment{ray, ns, pdf_wi};
        if (!through_media(segment, found, next, beta, L, depth)) break;
        wi = segment.ray.direction;
        add_emitted(L, beta, next, segment.ray.origin, segment.n, wi, segment.pdf);
      } else {
        add_lights_along(L, beta, ray.origin, ns, wi, found ? next.t : kInfinity, pdf_wi, !found);
        if (!found) break;
        add_emitted(L, beta, next, ray.origin, ns, wi, pdf_wi);
      }
      if (depth + 1 > plan.bounces) break;
      if (plan.russian_roulette && depth >= plan.russian_roulette_depth) {
        const double q = std::max(0.05, 1.0 - beta.max());
        if (sampler.roulette() < q) break;
        beta = beta * (1.0 / (1.0 - q));  // one division, not one per channel
      }
      wo = -wi;
      std::swap(hit_record, next_record);
    }
    return L;
  }

  // ---- Participating media ----

  // Transmittance along a shadow ray over [0, tmax), by ratio tracking (an unbiased estimate, in [0, 1] until the
  // roulette divides it).
  Rgb transmittance(const scene::Ray& ray) {
    return volume::ratio_tracking_transmittance(*ctx.medium, ray, ray.tmax, sampler.rng());
  }

  // Follows `segment` (whose closest hit, if `found`, is in `next`) through the media: each flight is sampled by
  // delta tracking; a scattering is a vertex (next-event estimation, then phase sampling into a new segment, which
  // is traced into `next`). Adds to L what the segments see of the media's emission, of the analytic lights and, on
  // escaping, of the infinite lights. True when the last segment reaches the surface in `next` with throughput beta
  // (its emission and reflection are the caller's); false when the path ends (absorbed, escaped, out of bounces, or
  // the roulette).
  bool through_media(Segment& segment, bool found, scene::Hit& next, Rgb& beta, Rgb& L, int& depth) {
    for (;;) {
      const scene::Ray& ray = segment.ray;
      const double t_hit = found ? next.t : kInfinity;
      if (ctx.has_analytic_lights) L += beta * analytic_lights_through_media(segment, t_hit);
      if (!ctx.media_scattering) return attenuated(segment, found, t_hit, beta, L);
      const volume::FreeFlight f = volume::sample_free_flight(*ctx.medium, ray, t_hit, sampler.rng());
      L += beta * f.emitted;
      beta = beta * f.weight;
      if (f.event == volume::FlightEvent::absorbed || !(beta.max() > 0) || !finite(beta)) return false;
      if (f.event == volume::FlightEvent::escaped) {
        if (found) return true;
        L += beta * escaped_radiance(ray.origin, segment.n, ray.direction, segment.pdf);
        return false;
      }
      if (depth + 1 > ctx.plan->bounces) return false;  // a scattering is a bounce
      ++depth;
      const Vec3 wo = -ray.direction;  // unit: every segment's direction is
      const volume::PhaseMixture phase = phase_at(f.p, f.properties);
      L += beta * next_event_in_medium(depth, f.p, wo, phase);
      const volume::PhaseMixture::Sample s = phase.sample(wo, sampler.lobe(depth), sampler.direction(depth));
      if (!(s.pdf > 0)) return false;
      beta = beta * s.weight;
      if (!roulette_survives(beta, depth)) return false;
      // At a scattering point there is no surface: MIS weights are taken about the direction of travel, which is
      // also the normal its light samples were drawn about (next_event_in_medium).
      segment = Segment{scene::Ray{f.p, s.wi, kInfinity}, -wo, s.pdf};
      found = trace(segment.ray, next);
    }
  }

  // Attenuation only: the segment's transmittance (ratio tracking) in place of a free flight; through_media's result.
  bool attenuated(const Segment& segment, bool found, double t_hit, Rgb& beta, Rgb& L) {
    const scene::Ray& ray = segment.ray;
    beta = beta * volume::ratio_tracking_transmittance(*ctx.medium, ray, t_hit, sampler.rng());
    if (!(beta.max() > 0)) return false;
    if (found) return true;
    L += beta * escaped_radiance(ray.origin, segment.n, ray.direction, segment.pdf);
    return false;
  }

  // Russian roulette as on surfaces: false ends the path; a survivor's beta is rescaled.
  bool roulette_survives(Rgb& beta, int depth) {
    if (!ctx.plan->russian_roulette || depth < ctx.plan->russian_roulette_depth) return true;
    const double q = std::max(0.05, 1.0 - beta.max());
    if (sampler.roulette() < q) return false;
    beta = beta * (1.0 / (1.0 - q));
    return true;
  }

  // The rect and disk lights a segment passes before t_hit, attenuated by a ratio-tracking estimate of the
  // transmittance to each (they do not end the path, so its own free flight cannot stand for it).
  Rgb analytic_lights_through_media(const Segment& segment, double t_hit) {
    const scene::Ray& ray = segment.ray;
    Rgb L;
    for (int index : ctx.analytic_lights) {
      const scene::LightSource& light = ctx.lights->light(index);
      const auto h = light.intersect(ray.origin, ray.direction, t_hit);
      if (!h) continue;
      const Rgb Le = light.Le(ray.origin, ray.direction, *h) *
                     mis_weight(segment.pdf, index, ray.origin, segment.n, ray.direction, *h);
      if (!(Le.max() > 0)) continue;
      L += Le * volume::ratio_tracking_transmittance(*ctx.medium, scene::Ray{ray.origin, ray.direction, h->distance},
                                                     h->distance, sampler.rng());
    }
    return L;
  }

  // The phase function at a scattering point: the medium's lobe, or the mixture where several overlap.
  volume::PhaseMixture phase_at(const Vec3& p, const volume::MediumProperties& mp) const {
    volume::PhaseMixture phase;
    if (ctx.media.size() == 1) {
      phase.add(ctx.media[0]->g(), mp.sigma_s);
    } else {
      for (const volume::Medium* m : ctx.media) phase.add(m->g(), m->at(p).sigma_s);
    }
    phase.finish();
    return phase;
  }

  // Next-event estimation at a scattering point p (vertex `vertex`, wo towards the previous vertex): one light by
  // power, one point on it, the phase function for the reflectance, the shadow ray's transmittance, and the balance
  // heuristic against phase sampling. Light samples are drawn about the direction of travel −wo (a light that
  // samples a hemisphere about a normal covers the other one by phase sampling alone, weighted 1 there).
  // (`direction`, when given, receives the light sample's direction.)
  Rgb next_event_in_medium(int vertex, const Vec3& p, const Vec3& wo, const volume::PhaseMixture& phase,
                           Vec3* direction = nullptr) {
    const auto choice = ctx.lights->sample(ctx.lights->single() ? 0.0 : sampler.light_choice(vertex));
    if (!choice) return Rgb{};
    const Point2 u = sampler.light_point(vertex);
    const std::optional<scene::LightSample> s = choice->index == ctx.emissive_light
                                                    ? ctx.lights->emissive()->sample(p, u)
                                                    : choice->light->sample_li(p, -wo, u);
    if (!s || !(s->Li.max() > 0)) return Rgb{};
    const Rgb f = phase.p(wo, s->wi);
    if (!(f.max() > 0)) return Rgb{};
    const scene::Ray ray =
        std::isfinite(s->distance) ? scene::shadow_ray(p, s->point) : scene::Ray{p, s->wi, kInfinity};
    if (!visible(ray)) return Rgb{};
    Rgb T{1.0};
    if constexpr (kMedia) T = transmittance(ray);  // a probe's next-event estimation in a scene without media
    if (!(T.max() > 0)) return Rgb{};
    if (direction) *direction = s->wi;
    double weight;
    if (s->delta) {
      weight = 1.0 / choice->pmf;
    } else {
      const double p_light = choice->pmf * s->pdf;
      if (!(p_light > 0)) return Rgb{};
      weight = ctx.plan->multiple_importance_sampling && !choice->light->uniform_in_solid_angle(p)
                   ? 1.0 / (p_light + phase.pdf(wo, s->wi))
                   : 1.0 / p_light;
    }
    return f * s->Li * T * weight;
  }
};

}  // namespace

void prepare_context(TransportContext& ctx) {
  ctx.textured = false;
  if (ctx.materials) {
    for (const ShadingMaterial& m : *ctx.materials) ctx.textured = ctx.textured || m.texture >= 0;
  }
  ctx.analytic_lights.clear();
  ctx.has_analytic_lights = false;
  ctx.emissive_light = -1;
  if (!ctx.lights) return;
  for (int i = 0; i < ctx.lights->size(); ++i) {
    const scene::LightSamplerKind kind = ctx.lights->light(i).kind();
    if (kind == scene::LightSamplerKind::rect || kind == scene::LightSamplerKind::disk)
      ctx.analytic_lights.push_back(i);
  }
  ctx.has_analytic_lights = !ctx.analytic_lights.empty();
  if (ctx.lights->emissive()) ctx.emissive_light = ctx.lights->index_of(ctx.lights->emissive());
}

std::vector<ShadingMaterial> shading_materials(const scene::Scene& scene, const plan::LightmapPlan& plan) {
  std::vector<ShadingMaterial> out;
  for (size_t i = 0; i < scene.materials.size(); ++i) {
    const scene::SceneMaterial& m = scene.materials[i];
    const plan::MaterialAnalysis* a = i < plan.materials.size() ? &plan.materials[i] : nullptr;
    brdf::MaterialSpec spec = m.bsdf;
    brdf::ModelSpec& s = spec.specular;
    if (a && !a->glossy && a->specular_albedo > 0) {
      // Pruned by the plan: a Lambertian lobe reflecting the lobe's average albedo Ē_s (w_s stays in the weights).
      const double e =
          spec.combine == brdf::Combine::weights ? a->specular_albedo / spec.specular_weight : a->specular_albedo;
      s = brdf::ModelSpec{};
      s.model = brdf::Model::lambert;
      s.albedo = Rgb{std::clamp(e, 0.0, 1.0)};
    } else if (!plan.anisotropy && s.alpha_x != s.alpha_y) {
      s.alpha_x = s.alpha_y = std::sqrt(s.alpha_x * s.alpha_y);
    }
    ShadingMaterial sm;
    sm.lambertian = brdf::lambertian_form(spec);
    // The general material tabulates its lobes' albedos when built (milliseconds each): only when it is used.
    if (!sm.lambertian) sm.bsdf = std::make_unique<brdf::Material>(spec);
    sm.base_color = m.base_color;
    sm.emission = m.emission;
    sm.emissive = m.emission.max() > 0;
    sm.two_sided = m.two_sided;
    if (m.base_color_texture && *m.base_color_texture >= 0 &&
        *m.base_color_texture < static_cast<int>(scene.textures.size())) {
      const scene::Texture& tex = scene.textures[*m.base_color_texture];
      if (plan.textures) {
        sm.texture = *m.base_color_texture;
      } else if (!tex.texels.empty()) {
        Rgb sum;
        for (const Rgb& c : tex.texels) sum += c;
        sm.texture_average = sum / static_cast<double>(tex.texels.size());
      }
    }
    if (sm.lambertian) sm.rho = sm.lambertian->A + sm.lambertian->B * (sm.base_color * sm.texture_average);
    out.push_back(std::move(sm));
  }
  return out;
}

namespace {

// Where a sampled ray from the receiver or a probe first met a surface.
struct FirstHit {
  bool found = false;
  double t = kInfinity;
  bool front_face = true;
};

// The radiance arriving at the ray's origin along the sampled ray (density pdf, MIS weights about n): what it meets
// through the media, the lights along it, the surface it reaches, emitting and reflecting up to the plan's bounces.
template <bool kMedia>
Rgb incoming_radiance(Walk<kMedia>& walk, const scene::Ray& ray, const Vec3& n, double pdf, FirstHit& first) {
  const TransportContext& ctx = walk.ctx;
  // Left uninitialised (~350 bytes a sample otherwise): the tracer writes every field of a record it reports a
  // hit in, and nothing reads one it has not.
  union HitRecords {
    scene::Hit records[2];
    HitRecords() {}
  } slots;
  scene::Hit(&records)[2] = slots.records;
  scene::Hit& hit = records[0];
  const bool found = walk.trace(ray, hit);
  first = found ? FirstHit{true, hit.t, hit.front_face} : FirstHit{};
  Rgb L;
  if constexpr (kMedia) {
    // Through the media first: the path may scatter before it reaches a surface.
    Segment segment{ray, n, pdf};
    Rgb beta{1.0};
    int depth = 0;
    if (walk.through_media(segment, found, hit, beta, L, depth)) {
      const Vec3 w = segment.ray.direction;
      walk.add_emitted(L, beta, hit, segment.ray.origin, segment.n, w, segment.pdf);
      if (depth + 1 <= ctx.plan->bounces) L += walk.reflected(&records[0], &records[1], -w, beta, depth + 1);
    }
  } else {
    walk.add_lights_along(L, Rgb{1.0}, ray.origin, n, ray.direction, found ? hit.t : kInfinity, pdf, !found);
    if (found) {
      walk.add_emitted(L, Rgb{1.0}, hit, ray.origin, n, ray.direction, pdf);
      if (ctx.plan->bounces >= 1) L += walk.reflected(&records[0], &records[1], -ray.direction);
    }
  }
  return L;
}

template <bool kMedia>
IrradianceEstimate estimate(const TransportContext& ctx, const Receiver& r, PathSampler& sampler) {
  IrradianceEstimate out;
  Walk<kMedia> walk{ctx, sampler, out};
  const scene::SurfacePoint& surface = r.surface;
  const Frame frame = Frame::from_normal(r.ns);
  auto cosine = [&](const Vec3& wi) { return Rgb{std::max(0.0, dot(wi, r.ns))}; };
  auto cosine_pdf = [&](const Vec3& wi) { return std::max(0.0, dot(wi, r.ns)) * kInvPi; };

  // 1. Light sampling.
  Rgb radiance;
  Vec3 direction;
  Rgb E = ctx.directional ? walk.next_event(0, surface, r.ns, cosine, cosine_pdf, &radiance, &direction)
                          : walk.next_event(0, surface, r.ns, cosine, cosine_pdf);
  if (ctx.directional) add_sh(out.sh, direction, radiance);

  // 2. Cosine sampling.
  const Vec3 local = sampler.cosine_direction(0);
  const Vec3 wi = frame.from_local(local);
  if (local.z > 0 && dot(wi, surface.ng) > 0) {
    const double pdf = local.z * kInvPi;
    const scene::Ray ray = scene::spawn_ray_front(surface, wi);  // dot(wi, ng) > 0, tested above
    FirstHit first;
    const Rgb L = incoming_radiance(walk, ray, r.ns, pdf, first);
    out.ao = (!first.found || (ctx.ao_distance > 0 && first.t > ctx.ao_distance)) ? 1.0 : 0.0;
    E += L * kPi;  // L cos θ / pdf with pdf = cos θ / π
    if (ctx.directional) add_sh(out.sh, wi, L / pdf);
  }
  if (!finite(E) ||
      (ctx.directional && (!finite(out.sh[0]) || !finite(out.sh[1]) || !finite(out.sh[2]) || !finite(out.sh[3])))) {
    // Never let one bad sample poison a texel: drop it whole, and say so (the report counts them).
    const uint32_t rays = out.rays, occlusion_rays = out.occlusion_rays;
    out = IrradianceEstimate{};
    out.rays = rays;
    out.occlusion_rays = occlusion_rays;
    out.dropped = true;
    return out;
  }
  out.E = E;
  return out;
}

}  // namespace

IrradianceEstimate estimate_irradiance(const TransportContext& ctx, const Receiver& r, PathSampler& sampler) {
  return ctx.medium ? estimate<true>(ctx, r, sampler) : estimate<false>(ctx, r, sampler);
}

namespace {

template <bool kMedia>
ProbeEstimate probe(const TransportContext& ctx, const Vec3& p, PathSampler& sampler) {
  IrradianceEstimate counts;
  Walk<kMedia> walk{ctx, sampler, counts};
  ProbeEstimate out;
  // The probe as an isotropic sensor: f = 1/(4π) over the sphere, the density of a uniform direction.
  volume::PhaseMixture sensor;
  sensor.add(0.0, Rgb{1.0});
  sensor.finish();
  const Vec3 up{0, 1, 0};
  Vec3 wi;
  const Rgb nee = walk.next_event_in_medium(0, p, -up, sensor, &wi);  // f·Li·w/p
  if (nee.max() > 0) add_sh9(out.sh, wi, nee * (4 * kPi));
  const Vec3 w = sample_uniform_sphere(sampler.direction(0));
  FirstHit first;
  const Rgb L = incoming_radiance(walk, scene::Ray{p, w, kInfinity}, up, kInv4Pi, first);
  out.back_face = first.found && !first.front_face;
  add_sh9(out.sh, w, L * (4 * kPi));
  out.rays = counts.rays;
  for (const Rgb& c : out.sh) {
    if (finite(c)) continue;
    // One bad sample must not poison a probe: dropped whole, and said.
    for (Rgb& z : out.sh) z = Rgb{};
    out.dropped = true;
    break;
  }
  return out;
}

}  // namespace

ProbeEstimate estimate_probe(const TransportContext& ctx, const Vec3& p, PathSampler& sampler) {
  return ctx.medium ? probe<true>(ctx, p, sampler) : probe<false>(ctx, p, sampler);
}

}  // namespace kiln::lightmap
