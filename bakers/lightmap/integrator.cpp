#include "bakers/lightmap/integrator.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "bakers/lightmap/path_sampler.h"
#include "bakers/lightmap/ray_log.h"
#include "bakers/math/constants.h"
#include "bakers/math/sampling.h"
#include "bakers/scene/emissive_triangles.h"
#include "bakers/scene/light_sampler.h"
#include "bakers/scene/ray_offset.h"
#include "bakers/scene/texture_sample.h"
#include "bakers/scene/tracer.h"

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

// The balance heuristic for a sample of density `a` against the other strategy's density `b`.
double balance(double a, double b) { return a > 0 ? a / (a + b) : 0.0; }

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
    if (escaped) {
      for (int index : ctx.lights->escape_lights()) {
        const scene::LightHit h;
        const scene::LightSource& light = ctx.lights->light(index);
        L += light.Le(p, wi, h) * mis_weight(pdf, index, p, n, wi, h);
      }
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
      *radiance = s.Li * weight;
      *direction = s.wi;
    }
    return fc * s.Li * weight;
  }

  // Radiance leaving *hit towards wo (world), reflected there at least once: path tracing with next-event
  // estimation; `depth` counts the reflections of the light arriving at the receiver. The two records take turns
  // as the vertex shaded and the next one found (swapped, never copied; a Hit is ~170 bytes).
  Rgb reflected(scene::Hit* hit_record, scene::Hit* next_record, Vec3 wo) {
    Rgb L, beta{1.0};
    const plan::LightmapPlan& plan = *ctx.plan;
    for (int depth = 1;; ++depth) {
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
      add_lights_along(L, beta, ray.origin, ns, wi, found ? next.t : kInfinity, pdf_wi, !found);
      if (!found) break;
      add_emitted(L, beta, next, ray.origin, ns, wi, pdf_wi);
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

IrradianceEstimate estimate_irradiance(const TransportContext& ctx, const Receiver& r, PathSampler& sampler) {
  IrradianceEstimate out;
  Walk walk{ctx, sampler, out};
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
    // Left uninitialised (~350 bytes a sample otherwise): the tracer writes every field of a record it reports a
    // hit in, and nothing reads one it has not.
    union HitRecords {
      scene::Hit records[2];
      HitRecords() {}
    } slots;
    scene::Hit(&records)[2] = slots.records;
    scene::Hit& hit = records[0];
    const bool found = walk.trace(ray, hit);
    Rgb L;
    walk.add_lights_along(L, Rgb{1.0}, ray.origin, r.ns, wi, found ? hit.t : kInfinity, pdf, !found);
    if (found) {
      walk.add_emitted(L, Rgb{1.0}, hit, ray.origin, r.ns, wi, pdf);
      if (ctx.plan->bounces >= 1) L += walk.reflected(&records[0], &records[1], -wi);
    }
    out.ao = (!found || (ctx.ao_distance > 0 && hit.t > ctx.ao_distance)) ? 1.0 : 0.0;
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

}  // namespace kiln::lightmap
