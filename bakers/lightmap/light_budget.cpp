#include "bakers/lightmap/light_budget.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <tbb/parallel_for.h>

#include "bakers/lightmap/texel_neighbourhood.h"

namespace kiln::lightmap {
namespace {

// Variances of texel (x, y)'s two parts, pooled over its traced neighbours.
TracedTexel pooled(const LightmapState& m, size_t mi, const LightTracer& tracer, ErrorMetric metric, double brightness,
                   int x, int y) {
  const LightmapImage& img = m.image;
  const int w = img.width(), h = img.height();
  const double rays = static_cast<double>(tracer.rays_traced());
  TracedTexel out;
  out.map = mi;
  out.texel = static_cast<size_t>(y) * w + x;
  double v = 0, c = 0, deposits = 0;
  int nv = 0, nc = 0;
  for_each_neighbour(x, y, w, h, [&](int xx, int yy) {
    const size_t i = static_cast<size_t>(yy) * w + xx;
    if (!m.traced[i]) return;
    const double eg = img.relative(i, img.gathered_standard_error(i), metric, brightness);
    if (std::isfinite(eg) && img.count(i) > 0) v += eg * eg * img.count(i), ++nv;
    const double ep = img.relative(i, img.traced_standard_error(i), metric, brightness);
    if (std::isfinite(ep)) c += ep * ep * rays, ++nc;
    deposits += static_cast<double>(tracer.deposits(mi, i));
  });
  out.v = nv ? v / nv : 0;
  out.c = nc ? c / nc : 0;
  out.min_rays = deposits > 0 ? rays * kMinDeposits / deposits : std::numeric_limits<double>::infinity();
  const double indirect = img.relative(out.texel, luminance(tracer.irradiance(mi, out.texel)), metric, brightness);
  out.y = std::isfinite(indirect) ? indirect : 0;
  return out;
}

// The cost of texel x's estimates at N rays (see the header comment).
double estimate_cost(const TracedTexel& x, double rays, double target_error, const GatherCosts& costs) {
  const double target2 = target_error * target_error;
  if (gathers_instead(x, rays, target_error)) {
    return costs.full * (x.v + kIndirectVariance * x.y * x.y) / target2;
  }
  return costs.direct * x.v / gathered_allowance(target2, x.c / rays);
}

}  // namespace

std::vector<TracedTexel> traced_texels(const std::vector<LightmapState>& maps, const LightTracer& tracer,
                                       ErrorMetric metric) {
  std::vector<TracedTexel> out;
  for (size_t mi = 0; mi < maps.size(); ++mi) {
    const LightmapState& m = maps[mi];
    if (m.traced.empty()) continue;
    const double brightness = metric == ErrorMetric::lightmap ? m.image.brightness() : 0.0;
    const int w = m.image.width(), h = m.image.height();
    std::vector<std::vector<TracedTexel>> rows(h);
    tbb::parallel_for(0, h, [&](int y) {
      for (int x = 0; x < w; ++x) {
        if (m.traced[static_cast<size_t>(y) * w + x])
          rows[y].push_back(pooled(m, mi, tracer, metric, brightness, x, y));
      }
    });
    for (const std::vector<TracedTexel>& row : rows) out.insert(out.end(), row.begin(), row.end());
  }
  return out;
}

bool gathers_instead(const TracedTexel& x, double rays, double target_error) {
  return rays < x.min_rays || x.c / rays > kTracedMaxShare * target_error * target_error;
}

double best_light_rays(const std::vector<TracedTexel>& texels, double target_error, double rays_now,
                       double cost_per_ray, const GatherCosts& costs) {
  double best = rays_now, best_cost = std::numeric_limits<double>::infinity();
  // A geometric grid is fine enough: the time is flat about its minimum.
  for (double rays = rays_now; rays <= 4096 * rays_now; rays *= 1.05) {
    double cost = cost_per_ray * rays;
    for (const TracedTexel& x : texels) cost += estimate_cost(x, rays, target_error, costs);
    if (cost < best_cost) best_cost = cost, best = rays;
  }
  return best;
}

}  // namespace kiln::lightmap
