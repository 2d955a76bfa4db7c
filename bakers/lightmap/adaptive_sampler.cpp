#include "bakers/lightmap/adaptive_sampler.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <span>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "bakers/lightmap/light_budget.h"
#include "bakers/lightmap/path_sampler.h"
#include "bakers/lightmap/texel_neighbourhood.h"
#include "bakers/math/rng.h"
#include "bakers/math/seed_mix.h"

namespace kiln::lightmap {
namespace {

using Clock = std::chrono::steady_clock;

// What one work item's estimates add to a texel, accumulated by its worker alone and then merged (merge()).
struct Partial {
  Rgb sum;               // of the accepted irradiance estimates
  ReplicaSums replicas;  // their luminances and counts per replica
  uint32_t tried = 0;    // accepted or dropped
  Rgb ao;
  std::array<Rgb, 4> sh{};
  std::array<double, 4> sh_y2{};

  // One accepted estimate of replica `replica`: irradiance E, AO, and (`directional`) the SH coefficients summed
  // with total sample weight `weight`.
  void add(int replica, const Rgb& E, const Rgb& ao_estimate, const std::array<Rgb, 4>& sh_weighted, double weight,
           bool directional) {
    sum += E;
    replicas.add(replica, luminance(E));
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

void merge(LightmapState& m, size_t t, const Partial& p) {
  m.attempts[t] += p.tried;
  m.image.merge(t, p.sum, p.replicas);
  if (!m.ao_sum.empty()) m.ao_sum[t] += p.ao;
  if (!m.sh_sum.empty()) {
    for (int c = 0; c < 4; ++c) {
      m.sh_sum[t][c] += p.sh[c];
      m.sh_y2[t][c] += p.sh_y2[c];
    }
  }
}

// ---- Scheduling ----

// Per texel, the variance of one estimate relative to the metric's luminance, v = n·error² (−1: none), and the
// share of target² left to the texel's own estimates (gathered_allowance, light_budget.h). Empty unless some texel of
// the lightmap has its min_samples: budget-bound bakes (min_samples = max_samples) never need it, and it is O(texels)
// per pass.
struct ErrorVariances {
  std::vector<double> v, allowance;
};

ErrorVariances error_variances(const LightmapState& m, const SamplingOptions& o) {
  const LightmapImage& img = m.image;
  bool any_adaptive = false;
  for (size_t t = 0; t < img.texel_count() && !any_adaptive; ++t) {
    any_adaptive = img.count(t) >= o.min_samples && m.attempts[t] < o.max_samples;
  }
  ErrorVariances ev;
  if (!any_adaptive) return ev;
  ev.v.assign(img.texel_count(), -1);
  ev.allowance.assign(img.texel_count(), o.target_error * o.target_error);
  const double brightness = o.metric == ErrorMetric::lightmap ? img.brightness() : 0.0;
  const double target2 = o.target_error * o.target_error;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, img.texel_count(), 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t t = r.begin(); t != r.end(); ++t) {
      if (!img.valid(t) || img.count(t) < kReplicas) continue;
      const double e = img.relative(t, img.gathered_standard_error(t), o.metric, brightness);
      ev.v[t] = std::isfinite(e) ? e * e * img.count(t) : -1;
      if (!m.traced.empty() && m.traced[t]) {
        const double p = img.relative(t, img.traced_standard_error(t), o.metric, brightness);
        ev.allowance[t] = gathered_allowance(target2, p * p);
      }
    }
  });
  return ev;
}

// The samples a texel needs, n = v/allowance (target² without light tracing), from v pooled over its 3 × 3
// neighbourhood: deciding from the texel's own variance alone biases the result low, since an estimate that has not
// yet met its rare large samples also looks precise (measured: 1-2 % low at a 2 % target in a furnace). Neighbours
// are independent estimates of nearly the same variance, which breaks that correlation; only neighbours that
// estimate the same light (all of it, or the direct light of a traced texel) are pooled. 0 when no neighbour has a
// variance.
double pooled_goal(const ErrorVariances& ev, const std::vector<uint8_t>& traced, int x, int y, int w, int h) {
  const size_t t = static_cast<size_t>(y) * w + x;
  const auto kind = [&](size_t i) { return traced.empty() ? 0 : traced[i]; };
  double sum = 0;
  int count = 0;
  for_each_neighbour(x, y, w, h, [&](int xx, int yy) {
    const size_t i = static_cast<size_t>(yy) * w + xx;
    const double vv = ev.v[i];
    if (vv >= 0 && kind(i) == kind(t)) sum += vv, ++count;
  });
  return count ? sum / count / ev.allowance[t] : 0;
}

// The estimates texel (x, y) gets this pass; 0 when it has enough.
uint64_t texel_batch(const LightmapState& m, const ErrorVariances& ev, int x, int y, const SamplingOptions& o,
                     double rare_event_paths) {
  const LightmapImage& img = m.image;
  const int w = img.width(), h = img.height();
  const size_t t = static_cast<size_t>(y) * w + x;
  if (!img.valid(t)) return 0;
  // Attempts, not kept estimates, bound the work: a texel whose estimates are all dropped (non-finite) would
  // otherwise be scheduled for ever.
  const uint64_t tried = m.attempts[t];
  if (tried >= o.max_samples) return 0;
  const uint64_t n = img.count(t);
  double goal = static_cast<double>(o.min_samples);
  if (n >= o.min_samples) {
    // Every estimate traces one path per sample point of the texel.
    const double paths_per_estimate = static_cast<double>(std::max<size_t>(1, m.texels.at(t).size()));
    goal = std::max(pooled_goal(ev, m.traced, x, y, w, h), std::ceil(rare_event_paths / paths_per_estimate));
  }
  const double want = std::ceil(goal) - static_cast<double>(n);
  if (!(want >= 1)) return 0;
  // Whole rounds of the replicas, so that they stay equal in count (and each replica's sequence in whole runs).
  const auto round_up = [](uint64_t k) { return (k + kReplicas - 1) / kReplicas * kReplicas; };
  const uint64_t growth = round_up(std::max<uint64_t>(1, tried / 2));
  return std::min({round_up(static_cast<uint64_t>(std::min(want, 1e12))), growth, o.max_samples - tried});
}

// One lightmap's batches, row-parallel, concatenated in row order.
void schedule_lightmap(const LightmapState& m, uint32_t map, const SamplingOptions& o, double rare_event_paths,
                       std::vector<TexelBatch>& out) {
  const ErrorVariances ev = error_variances(m, o);
  const int w = m.image.width(), h = m.image.height();
  std::vector<std::vector<TexelBatch>> rows(h);
  tbb::parallel_for(tbb::blocked_range<int>(0, h, 8), [&](const tbb::blocked_range<int>& ry) {
    for (int y = ry.begin(); y != ry.end(); ++y) {
      for (int x = 0; x < w; ++x) {
        const uint64_t batch = texel_batch(m, ev, x, y, o, rare_event_paths);
        if (batch > 0) rows[y].push_back({map, static_cast<uint32_t>(batch), static_cast<size_t>(y) * w + x});
      }
    }
  });
  for (const std::vector<TexelBatch>& row : rows) out.insert(out.end(), row.begin(), row.end());
}

// ---- Running a pass ----

// Normally one work item per texel, whose worker owns the texel and merges into it directly. When few texels remain
// (late adaptive passes, where batches are large), one texel's batch is split over several items so that every core
// gets work; their partial sums are merged after the pass.
struct WorkItem {
  uint32_t map, count;
  size_t texel;
  uint64_t first;   // index of the item's first estimate among all the texel's estimates
  int64_t partial;  // into the pass's partial sums, or −1: merge directly
};

std::vector<WorkItem> work_items(const std::vector<TexelBatch>& batches, const std::vector<LightmapState>& maps,
                                 size_t& partials) {
  std::vector<WorkItem> items;
  partials = 0;
  // Fixed, not from the thread count (the split decides the streams, so the bytes would follow the machine):
  // enough items for a few dozen cores. Pieces are whole rounds of the replicas.
  constexpr size_t spread = 1024;
  if (batches.size() >= spread) {
    items.reserve(batches.size());
    for (const TexelBatch& j : batches) {
      items.push_back({j.map, j.batch, j.texel, maps[j.map].attempts[j.texel], -1});
    }
    return items;
  }
  const uint64_t pieces = (spread + batches.size() - 1) / batches.size();
  for (const TexelBatch& j : batches) {
    const uint64_t size =
        (std::max<uint64_t>(1, (j.batch + pieces - 1) / pieces) + kReplicas - 1) / kReplicas * kReplicas;
    const uint64_t start = maps[j.map].attempts[j.texel];
    for (uint64_t done = 0; done < j.batch; done += size) {
      const auto count = static_cast<uint32_t>(std::min<uint64_t>(size, j.batch - done));
      items.push_back({j.map, count, j.texel, start + done, static_cast<int64_t>(partials++)});
    }
  }
  return items;
}

// One estimate of a texel's irradiance (and AO, SH): a path per sample point, each weighted by the point's share of
// the texel, each point with its own sequences in replica `replica` (path_sampler.h). `bad` when some path's
// contribution was dropped; the weight covers the paths kept.
struct TexelEstimate {
  Rgb E, ao;
  std::array<Rgb, 4> sh{};
  double weight = 0;
  bool bad = false;
};

TexelEstimate estimate_texel(const LightmapState& m, size_t t, const TransportContext& ctx, bool directional,
                             uint64_t texel_seed, uint64_t estimate, Pcg32& rng, PassCounts& counts) {
  const std::span<const TexelSample> samples = m.texels.at(t);
  const uint64_t replica = estimate % kReplicas;
  const auto index = static_cast<uint32_t>(estimate / kReplicas);
  TexelEstimate s;
  for (size_t k = 0; k < samples.size(); ++k) {
    const Receiver rec = receiver_of(samples[k]);
    PathSampler sampler(mix_seeds(texel_seed, k * kReplicas + replica), index, rng);
    const IrradianceEstimate e = estimate_irradiance(ctx, rec, sampler);
    counts.rays += e.rays;
    counts.occlusion_rays += e.occlusion_rays;
    counts.general_vertices += e.general_vertices;
    ++counts.paths;
    if (e.dropped) {
      s.bad = true;
      continue;
    }
    const double w = samples[k].weight;
    s.E += e.E * w;
    s.ao += Rgb{e.ao * w};
    if (directional) {
      for (int c = 0; c < 4; ++c) s.sh[c] += e.sh[c] * w;
    }
    s.weight += w;
  }
  return s;
}

// An item's estimates: quasi-random sequences per texel, sample point and replica; a pseudo-random stream of its own
// for the deeper path vertices.
Partial estimate_item(const LightmapState& m, const WorkItem& item, const TransportContext& full_ctx,
                      const TransportContext* direct_ctx, const SamplingOptions& o, PassCounts& counts) {
  const bool traced = direct_ctx && !m.traced.empty() && m.traced[item.texel];
  const TransportContext& ctx = traced ? *direct_ctx : full_ctx;
  // By the texel's page and its place there (LightmapState::page_texel), not its index in this pass's states.
  const uint64_t texel_seed = mix_seeds(mix_seeds(o.seed, m.page), m.page_texel(item.texel));
  Pcg32 rng(mix_seeds(texel_seed, item.first));
  Partial p;
  const uint64_t rays_before = counts.rays;
  counts.estimates += item.count;
  if (traced) counts.traced_estimates += item.count;
  for (uint32_t b = 0; b < item.count; ++b) {
    ++p.tried;
    const uint64_t estimate = item.first + b;
    const TexelEstimate s = estimate_texel(m, item.texel, ctx, o.directional, texel_seed, estimate, rng, counts);
    if (s.bad) ++counts.dropped;
    if (!(s.weight > 0)) continue;
    const double inv_weight = 1.0 / s.weight;  // one division for the four channels below
    const Rgb irradiance = s.E * inv_weight;
    if (!LightmapImage::acceptable(irradiance)) {
      ++counts.dropped;
      continue;
    }
    p.add(static_cast<int>(estimate % kReplicas), irradiance, s.ao * inv_weight, s.sh, s.weight, o.directional);
  }
  if (traced) counts.traced_rays += counts.rays - rays_before;
  return p;
}

// Sums the workers' counts.
struct SharedCounts {
  std::atomic<uint64_t> rays{0}, occlusion_rays{0}, paths{0}, general_vertices{0}, dropped{0};
  std::atomic<uint64_t> estimates{0}, traced_estimates{0}, traced_rays{0};
  std::atomic<bool> out_of_time{false};

  void add(const PassCounts& c) {
    rays.fetch_add(c.rays, std::memory_order_relaxed);
    occlusion_rays.fetch_add(c.occlusion_rays, std::memory_order_relaxed);
    paths.fetch_add(c.paths, std::memory_order_relaxed);
    general_vertices.fetch_add(c.general_vertices, std::memory_order_relaxed);
    dropped.fetch_add(c.dropped, std::memory_order_relaxed);
    estimates.fetch_add(c.estimates, std::memory_order_relaxed);
    traced_estimates.fetch_add(c.traced_estimates, std::memory_order_relaxed);
    traced_rays.fetch_add(c.traced_rays, std::memory_order_relaxed);
  }
  PassCounts total() const {
    return {rays.load(),       occlusion_rays.load(), paths.load(),     general_vertices.load(),
            dropped.load(),    out_of_time.load(),    estimates.load(), traced_estimates.load(),
            traced_rays.load()};
  }
};

}  // namespace

std::vector<TexelBatch> schedule_pass(const std::vector<LightmapState>& maps, const SamplingOptions& options) {
  // Rule of three: n paths that never met some contribution only say that its probability per path is below 3/n
  // (95 % confidence). A texel whose estimates barely vary (in the open under a constant sky, or black) would stop
  // at min_samples while missing anything that only some of its paths find; no texel stops before its paths (over
  // all its sample points) number 3/target, i.e. before anything reaching it through more than a fraction `target`
  // of its paths would have shown. (Texels with real variance need more than this anyway once v > 3·target.)
  const double rare_event_paths = std::ceil(3.0 / options.target_error);
  std::vector<TexelBatch> batches;
  for (size_t mi = 0; mi < maps.size(); ++mi) {
    schedule_lightmap(maps[mi], static_cast<uint32_t>(mi), options, rare_event_paths, batches);
  }
  return batches;
}

PassCounts run_pass(std::vector<LightmapState>& maps, const std::vector<TexelBatch>& batches,
                    const TransportContext& ctx, const SamplingOptions& options, const bake::BakeControl& control,
                    const TransportContext* direct_ctx) {
  size_t partial_count = 0;
  const std::vector<WorkItem> items = work_items(batches, maps, partial_count);
  std::vector<Partial> partials(partial_count);
  SharedCounts shared;
  // Grain: up to 16 items per task, fewer when there are few, so that every core gets work.
  const size_t grain = std::clamp<size_t>(items.size() / 32, 1, 16);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, items.size(), grain), [&](const tbb::blocked_range<size_t>& r) {
    if (control.cancel && control.cancel->load()) return;
    PassCounts local;
    for (size_t j = r.begin(); j != r.end(); ++j) {
      // The time limit holds inside a pass too: the texels not reached keep what they have.
      if (shared.out_of_time.load(std::memory_order_relaxed)) break;
      if (Clock::now() >= options.deadline) {
        shared.out_of_time = true;
        break;
      }
      const WorkItem& item = items[j];
      const Partial p = estimate_item(maps[item.map], item, ctx, direct_ctx, options, local);
      if (item.partial < 0) {
        merge(maps[item.map], item.texel, p);
      } else {
        partials[item.partial] = p;
      }
    }
    shared.add(local);
  });
  for (const WorkItem& item : items) {
    if (item.partial >= 0) merge(maps[item.map], item.texel, partials[item.partial]);
  }
  return shared.total();
}

}  // namespace kiln::lightmap
