#include "bakers/lightmap/light_tracing.h"

#include <algorithm>
#include <cmath>

#include <sys/mman.h>

#include <tbb/parallel_for.h>

#include "bakers/lightmap/ray_log.h"
#include "bakers/math/rng.h"
#include "bakers/math/seed_mix.h"
#include "bakers/scene/light_sampler.h"
#include "bakers/scene/ray_offset.h"
#include "bakers/scene/scene_check.h"
#include "bakers/scene/texture_sample.h"
#include "bakers/scene/tracer.h"

namespace kiln::lightmap {
namespace {

bool flat(const TexelSample& s) { return dot(s.shading_normal, s.geometric_normal) >= kFlatNormalCos; }

}  // namespace

template <class T>
T* LightTracer::HugePages<T>::allocate(size_t n) {
  constexpr size_t kPage = size_t{2} << 20;
  const size_t bytes = (n * sizeof(T) + kPage - 1) / kPage * kPage;
  void* p = std::aligned_alloc(kPage, bytes);
  if (!p) throw std::bad_alloc();
  madvise(p, bytes, MADV_HUGEPAGE);  // a request: without huge pages the memory is as good
  return static_cast<T*>(p);
}

const size_t LightTracer::kBytesPerTexel = sizeof(LightTracer::TexelSums);

size_t mark_traced_texels(LightmapState& m) {
  const LightmapTexels& texels = m.texels;
  m.traced.assign(texels.texel_count(), 0);
  size_t n = 0;
  for (size_t t = 0; t < texels.texel_count(); ++t) {
    if (!texels.valid(t)) continue;
    bool ok = true;
    for (const TexelSample& s : texels.at(t)) ok = ok && !s.leak_fixed && flat(s);
    m.traced[t] = ok;
    n += ok;
  }
  return n;
}

// Deposits waiting to be added. They land anywhere in the lightmaps' sums, and adding each as its ray arrived
// stalled on memory for a fifth of the tracing time: added in runs, the sums of those further down the run are
// fetched while the earlier ones are added.
class LightTracer::PendingDeposits {
 public:
  PendingDeposits() { pending_.reserve(kRun); }

  void add(TexelSums* s, const Rgb& beta, double unit, int replica) {
    const Rgb q = beta * (1.0 / unit);
    pending_.push_back(
        {s, {std::llround(q.r), std::llround(q.g), std::llround(q.b)}, std::llround(luminance(q)), replica});
    if (pending_.size() == kRun) flush();
  }
  // Deposits added into traced texels so far (flush() first).
  uint64_t added() const { return added_; }

  void flush() {
    constexpr size_t kAhead = 8;  // sums in flight: enough to cover a fetch from memory
    for (size_t i = 0; i < pending_.size(); ++i) {
      if (i + kAhead < pending_.size()) {
        const char* ahead = reinterpret_cast<const char*>(pending_[i + kAhead].sums);
        __builtin_prefetch(ahead, 1);
        __builtin_prefetch(ahead + 64, 1);
      }
      apply(pending_[i]);
    }
    pending_.clear();
  }

 private:
  static constexpr size_t kRun = 1024;  // 48 KiB: stays in the core's cache
  struct Deposit {
    TexelSums* sums;
    int64_t flux[3];
    int64_t flux_y;
    int replica;
  };

  void apply(const Deposit& d) {
    TexelSums& s = *d.sums;
    if (!(s.area > 0)) return;  // not a traced texel
    const auto add = [](int64_t& to, int64_t v) {
      std::atomic_ref<int64_t>(to).fetch_add(v, std::memory_order_relaxed);
    };
    for (int c = 0; c < 3; ++c) add(s.flux[c], d.flux[c]);
    add(s.flux_y[d.replica], d.flux_y);
    add(s.deposits, 1);
    ++added_;
  }

  std::vector<Deposit> pending_;
  uint64_t added_ = 0;
};

// One ray from a light and its reflections: deposits into the traced texels it reaches.
struct LightTracer::Walker {
  LightTracer& lt;
  Pcg32& rng;
  PendingDeposits& pending;
  uint64_t rays = 0;

  Point2 uniform2() {
    const double u = rng.uniform32();
    return {u, rng.uniform32()};
  }

  bool trace(const scene::Ray& ray, scene::Hit& hit) {
    ++rays;
    if (lt.ctx_.ray_log) lt.ctx_.ray_log->record(ray, RayKind::closest);
    return lt.ctx_.tracer->intersect(ray, hit, scene::HitDetail{.lightmap_uv = true, .uv = lt.ctx_.textured});
  }

  // Deposits `beta` into the sums of the texel at `hit`'s front, if it has a lightmap (whether the texel is traced is
  // looked up when the deposit is added).
  void deposit(const scene::Hit& hit, const Rgb& beta, int replica) {
    if (!hit.front_face) return;  // a lightmap receives on its front side
    const int map = lt.map_of_instance_[hit.instance];
    if (map < 0) return;
    Receiving& r = lt.maps_[map];
    const int x = std::clamp(static_cast<int>(hit.lightmap_uv.x * r.width), 0, r.width - 1);
    const int y = std::clamp(static_cast<int>(hit.lightmap_uv.y * r.height), 0, r.height - 1);
    pending.add(&r.texels[static_cast<size_t>(y) * r.width + x], beta, lt.unit_, replica);
  }

  // The reflection at `hit` of light that arrived travelling along `dir`: the new direction, with beta updated;
  // false when the light is absorbed there.
  bool reflect(const scene::Hit& hit, const Vec3& dir, Rgb& beta, scene::Ray& ray) {
    const ShadingMaterial& m = (*lt.ctx_.materials)[hit.material];
    scene::SurfacePoint surface = hit.surface();
    Vec3 ns = hit.ns;
    if (!hit.front_face) {  // either side reflects
      surface.ng = -surface.ng;
      ns = -ns;
    }
    const Vec3 wi = -dir;  // towards where the light came from
    const double cos_ng_wi = dot(wi, surface.ng), cos_ns_wi = dot(wi, ns);
    // Arriving below the shading normal's horizon: f cos θ_s = 0, nothing reflects (as in the transport). A hit has
    // cos_ng_wi > 0 on the side it arrived from; its ratio below needs it.
    if (!(cos_ns_wi > 0) || !(cos_ng_wi > 0)) return false;
    const Frame frame = Frame::from_normal(ns);
    Vec3 wo;
    Rgb f_over_pdf;  // f(wo, wi) / pdf(wo)
    if (m.lambertian) {
      const Rgb rho = m.texture < 0 ? m.rho : m.lambertian->A + m.lambertian->B * tint(m, hit);
      const Vec3 local = sample_cosine_hemisphere(rng);
      if (!(local.z > 0)) return false;  // on the rim: cos θ = 0 carries nothing
      wo = frame.from_local(local);
      f_over_pdf = rho * (1.0 / local.z);  // (ρ/π) / (cos θ_o / π)
    } else {
      const Rgb t = tint(m, hit);
      const Vec3 wi_local = frame.to_local(wi);
      // Drawn as the BSDF samples its second direction given the first; evaluated in light's order.
      const std::optional<brdf::BsdfSample> s = m.bsdf->sample(wi_local, uniform2(), rng.uniform32(), t);
      if (!s) return false;
      wo = frame.from_local(s->wi);
      f_over_pdf = m.bsdf->eval(s->wi, wi_local, t) * (1.0 / s->pdf);
    }
    const double cos_ng_wo = dot(wo, surface.ng);
    if (!(cos_ng_wo > 0)) return false;  // into the surface (the shading normal disagrees with the geometry)
    beta = beta * f_over_pdf * (cos_ns_wi * cos_ng_wo / cos_ng_wi);
    if (!(beta.max() > 0) || !beta.is_finite()) return false;
    ray = scene::spawn_ray_front(surface, wo);
    return true;
  }

  Rgb tint(const ShadingMaterial& m, const scene::Hit& hit) const {
    if (m.texture < 0) return m.base_color * m.texture_average;
    return m.base_color * scene::sample_bilinear(lt.ctx_.scene->textures[m.texture], hit.uv);
  }

  void walk(uint64_t index) {
    const int replica = static_cast<int>(index % kReplicas);
    const scene::AliasTable::Choice choice = lt.choice_.sample(rng.uniform32());
    const scene::LightSource& light = lt.ctx_.lights->light(lt.lights_[choice.index]);
    const std::optional<scene::LightEmission> e = light.sample_le(uniform2(), uniform2());
    if (!e) return;
    const Rgb emitted = e->weight * (1.0 / choice.pmf);
    const scene::Ray ray = e->offset > 0
                               ? scene::spawn_ray(scene::SurfacePoint(e->origin, e->ng, e->offset), e->direction)
                               : scene::Ray{e->origin, e->direction};
    scene::Hit first;
    if (!trace(ray, first) || lt.bounces_ < 1) return;
    // The first hit receives only direct light, which gathering brings: its reflections are where deposits start,
    // and each carries 1/kFirstReflections of the flux.
    const Rgb share = emitted * (1.0 / kFirstReflections);
    for (int k = 0; k < kFirstReflections; ++k) {
      Rgb beta = share;
      scene::Ray next;
      if (reflect(first, ray.direction, beta, next) && roulette(beta, share.max()))
        follow(next, beta, share.max(), replica);
    }
  }

  // Russian roulette relative to the flux `start` the ray set out with; false when the ray ends.
  bool roulette(Rgb& beta, double start) {
    const double survive = std::min(1.0, beta.max() / start);
    if (survive < 1) {
      if (rng.uniform32() >= survive) return false;
      beta = beta * (1.0 / survive);
    }
    return true;
  }

  // A ray that has reflected once, with flux `beta`, to its end: deposits where it lands, reflects again.
  void follow(scene::Ray ray, Rgb beta, double start, int replica) {
    scene::Hit hit;
    for (int reflections = 1;; ++reflections) {
      if (!trace(ray, hit)) return;
      deposit(hit, beta, replica);
      if (reflections + 1 > lt.bounces_) return;
      const Vec3 dir = ray.direction;
      if (!reflect(hit, dir, beta, ray) || !roulette(beta, start)) return;
    }
  }
};

LightTracer::LightTracer(const TransportContext& ctx, const std::vector<LightmapState>& maps, int bounces,
                         uint64_t seed)
    : ctx_(ctx), bounces_(bounces), seed_(seed) {
  const scene::Scene& s = *ctx.scene;
  std::vector<double> weights;
  double total = 0;
  for (int i = 0; i < ctx.lights->size(); ++i) {
    const scene::LightSource& light = ctx.lights->light(i);
    const double power = luminance(light.power(ctx.lights->scene_radius()));
    if (!light.emits_rays() || !(power > 0) || !std::isfinite(power)) continue;
    // Exactly the light gathering would see: a delta light the plan does not sample (forced off) reaches no path.
    if (light.is_delta() && !(ctx.lights->pmf(i) > 0)) continue;
    lights_.push_back(i);
    weights.push_back(power);
    total += light.power(ctx.lights->scene_radius()).max();
  }
  choice_ = scene::AliasTable(weights);
  unit_ = (total > 0 ? total : 1.0) * 0x1.0p-24;
  map_of_instance_.assign(s.instances.size(), -1);
  for (size_t i = 0; i < s.instances.size(); ++i) {
    if (!s.instances[i].bake) continue;
    const std::string name = scene::resolved_lightmap_name(s, s.instances[i]);
    for (size_t m = 0; m < maps.size(); ++m) {
      if (maps[m].name == name) map_of_instance_[i] = static_cast<int>(m);
    }
  }
  for (const LightmapState& m : maps) {
    Receiving r;
    r.width = m.texels.width;
    r.height = m.texels.height;
    const size_t n = m.texels.texel_count();
    r.texels.assign(n, TexelSums{});
    for (size_t t = 0; t < n; ++t) {
      if (m.traced.empty() || !m.traced[t]) continue;
      // Each point stands for `weight` of the texel, on a triangle where a texel has texel_world_size² of area.
      for (const TexelSample& p : m.texels.at(t)) {
        r.texels[t].area += p.weight * static_cast<double>(p.texel_world_size) * p.texel_world_size;
      }
    }
    maps_.push_back(std::move(r));
  }
}

LightTracingCounts LightTracer::trace(uint64_t count, std::chrono::steady_clock::time_point deadline,
                                      const std::atomic<bool>* cancel) {
  LightTracingCounts total;
  if (!active() || count == 0) return total;
  const uint64_t blocks = (count + kBlock - 1) / kBlock;
  const uint64_t first_block = next_block_;
  std::atomic<uint64_t> rays{0}, deposits{0}, done{0};
  std::atomic<bool> stop{false};
  tbb::parallel_for(uint64_t{0}, blocks, [&](uint64_t b) {
    if (stop.load(std::memory_order_relaxed)) return;
    if ((cancel && cancel->load()) || std::chrono::steady_clock::now() >= deadline) {
      stop = true;
      return;
    }
    const uint64_t block = first_block + b;
    Pcg32 rng(mix_seeds(seed_, block));
    PendingDeposits pending;
    Walker w{*this, rng, pending};
    for (uint64_t i = block * kBlock; i < (block + 1) * kBlock; ++i) w.walk(i);
    pending.flush();
    rays += w.rays;
    deposits += pending.added();
    ++done;
  });
  // Blocks skipped at the deadline leave a gap in the sequence: the next call starts after the last block asked for,
  // and only the blocks traced count.
  next_block_ += blocks;
  traced_ += done.load() * kBlock;
  total.rays = rays;
  total.deposits = deposits;
  total.out_of_time = stop;
  return total;
}

Rgb LightTracer::irradiance(size_t map, size_t texel) const {
  const TexelSums& s = maps_[map].texels[texel];
  if (!(s.area > 0) || traced_ == 0) return {};
  const double k = unit_ / (s.area * static_cast<double>(traced_));
  const auto& f = s.flux;
  return Rgb{static_cast<double>(f[0]) * k, static_cast<double>(f[1]) * k, static_cast<double>(f[2]) * k};
}

std::array<double, kReplicas> LightTracer::replica_luminance(size_t map, size_t texel) const {
  std::array<double, kReplicas> out{};
  const TexelSums& s = maps_[map].texels[texel];
  if (!(s.area > 0) || traced_ == 0) return out;
  const double k = unit_ * kReplicas / (s.area * static_cast<double>(traced_));
  for (int i = 0; i < kReplicas; ++i) out[i] = static_cast<double>(s.flux_y[i]) * k;
  return out;
}

}  // namespace kiln::lightmap
