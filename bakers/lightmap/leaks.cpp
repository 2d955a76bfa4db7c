#include "bakers/lightmap/leaks.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "bakers/bake/number_format.h"
#include "bakers/math/constants.h"
#include "bakers/scene/ray_offset.h"

namespace kiln::lightmap {
namespace {

void check(const LeakOptions& o) {
  const auto fail = [](const std::string& field, const std::string& want, double got) {
    throw std::invalid_argument("leak handling: " + field + " must be " + want + ", got " + bake::format_number(got));
  };
  if (o.rings < 1 || o.rings > 64) fail("rings", "in [1, 64]", o.rings);
  if (o.sectors < 1 || o.sectors > 64) fail("sectors", "in [1, 64]", o.sectors);
  if (!(o.max_backface_fraction >= 0 && o.max_backface_fraction < 1)) {
    fail("max_backface_fraction", "in [0, 1)", o.max_backface_fraction);
  }
  if (!(o.probe_distance_texels > 0)) fail("probe_distance_texels", "> 0", o.probe_distance_texels);
  if (!(o.move_distance_texels >= 0) || !std::isfinite(o.move_distance_texels)) {
    fail("move_distance_texels", "finite and >= 0", o.move_distance_texels);
  }
  if (!(o.push_texels > 0) || !std::isfinite(o.push_texels)) fail("push_texels", "finite and > 0", o.push_texels);
  if (!(o.origin_offset_texels >= 0) || !std::isfinite(o.origin_offset_texels)) {
    fail("origin_offset_texels", "finite and >= 0", o.origin_offset_texels);
  }
  if (o.max_move_attempts < 0) fail("max_move_attempts", ">= 0", o.max_move_attempts);
}

struct BackHit {
  double t;
  Vec3 point, front_normal;
};

struct Probe {
  double backface_fraction = 0;    // of the rays traced while the verdict was open
  bool clear = false;              // backface_fraction ≤ max_backface_fraction over all the directions
  std::vector<BackHit> back_hits;  // the nearest `max_candidates` within the move distance, nearest first
};

// Whether `back` back faces among `n` rays leave a probe clear.
bool clear_with(int back, size_t n, const LeakOptions& o) {
  return static_cast<double>(back) / static_cast<double>(n) <= o.max_backface_fraction;
}

// The probe's directions in the local frame of n (+z), the same for every probe of a bake: computed once.
std::vector<Vec3> probe_directions(const LeakOptions& o) {
  std::vector<Vec3> out;
  out.reserve(static_cast<size_t>(o.rings) * o.sectors);
  for (int i = 0; i < o.rings; ++i) {
    // Uniform over the hemisphere: cos θ is uniform on [0, 1]; cell centres.
    const double cos_theta = (i + 0.5) / o.rings;
    const double sin_theta = std::sqrt(std::max(0.0, 1.0 - cos_theta * cos_theta));
    for (int j = 0; j < o.sectors; ++j) {
      const double phi = 2.0 * kPi * (j + 0.5 + 0.5 * (i % 2)) / o.sectors;
      out.push_back({sin_theta * std::cos(phi), sin_theta * std::sin(phi), cos_theta});
    }
  }
  return out;
}

// Keeps `hits` the nearest `max_candidates` back faces seen, nearest first (ties in the order of the directions).
void offer_candidate(std::vector<BackHit>& hits, const BackHit& h, size_t max_candidates) {
  const auto at = std::upper_bound(hits.begin(), hits.end(), h.t, [](double t, const BackHit& b) { return t < b.t; });
  if (static_cast<size_t>(at - hits.begin()) >= max_candidates) return;
  hits.insert(at, h);
  if (hits.size() > max_candidates) hits.pop_back();
}

enum class Verdict { open, clear, inside };

// A probe's verdict is decided once too many back faces are seen for it to be clear, or too few rays are left to
// reach that many: the rays after that cannot change it.
Verdict verdict_after(int back, size_t done, size_t n, const LeakOptions& o) {
  if (!clear_with(back, n, o)) return Verdict::inside;
  return clear_with(back + static_cast<int>(n - done), n, o) ? Verdict::clear : Verdict::open;
}

// Once a probe is inside, a ray left matters only by a back face that would be one of the nearest `max_candidates`
// within the move distance: how far it must reach for that, 0 if no face can be.
double candidate_reach(const Probe& so_far, double move_distance, size_t max_candidates) {
  if (max_candidates == 0 || !(move_distance > 0)) return 0;
  return so_far.back_hits.size() < max_candidates ? move_distance : so_far.back_hits.back().t;
}

// One probe of the rule in leaks.h, keeping its nearest `max_candidates` back faces within `move_distance` (none for a
// candidate's probe, whose verdict alone matters). Ends early as leaks.h says: the same verdict and candidates.
Probe probe(const Vec3& p, const Vec3& n, double s, double ray_offset, const RayQuery& rays, const LeakOptions& o,
            const std::vector<Vec3>& directions, double move_distance, size_t max_candidates, uint32_t& traced) {
  // Above the surface by the larger of the float tracer's bound and a fraction of the texel (leaks.h).
  const scene::SurfacePoint surface{p, n, std::max(ray_offset, o.origin_offset_texels * s)};
  const Frame frame = Frame::from_normal(n);
  const double tmax = o.probe_distance_texels * s;
  Probe result;
  int back = 0;
  size_t open = 0;  // rays traced while the verdict was open
  for (size_t i = 0; i < directions.size(); ++i) {
    const Verdict verdict = o.end_probes_early ? verdict_after(back, i, directions.size(), o) : Verdict::open;
    if (verdict == Verdict::clear) break;
    const double reach =
        verdict == Verdict::open ? tmax : std::min(tmax, candidate_reach(result, move_distance, max_candidates));
    if (!(reach > 0)) break;
    const Vec3 dir = frame.from_local(directions[i]);
    ++traced;
    const Vec3 origin = scene::offset_ray_origin(surface, dir);
    const std::optional<HitInfo> hit = rays.intersect(origin, dir, reach);
    if (verdict == Verdict::open) ++open;
    if (!hit || hit->front_face) continue;
    if (verdict == Verdict::open) ++back;
    if (hit->t <= move_distance) {
      offer_candidate(result.back_hits, {hit->t, origin + dir * hit->t, hit->geometric_normal}, max_candidates);
    }
  }
  result.backface_fraction = static_cast<double>(back) / static_cast<double>(open);
  result.clear = clear_with(back, directions.size(), o);
  return result;
}

// resolve_leak for checked options and their probe directions.
LeakResult resolve(const TexelSample& sample, const RayQuery& rays, const LeakOptions& options,
                   const std::vector<Vec3>& directions) {
  const double s = sample.texel_world_size;
  const double move_distance = options.move_distance_texels * s;
  LeakResult result;
  result.position = sample.position;
  const Probe first = probe(sample.position, sample.geometric_normal, s, sample.ray_offset, rays, options, directions,
                            move_distance, static_cast<size_t>(options.max_move_attempts), result.rays);
  result.backface_fraction = first.backface_fraction;
  if (first.clear) return result;

  for (const BackHit& h : first.back_hits) {
    const Vec3 candidate = h.point + h.front_normal * (options.push_texels * s);
    const Probe there =
        probe(candidate, sample.geometric_normal, s, sample.ray_offset, rays, options, directions, 0.0, 0, result.rays);
    if (there.clear) {
      result.verdict = LeakVerdict::moved;
      result.position = candidate;
      return result;
    }
  }
  result.verdict = LeakVerdict::invalid;
  return result;
}

}  // namespace

LeakResult resolve_leak(const TexelSample& sample, const RayQuery& rays, const LeakOptions& options) {
  check(options);
  return resolve(sample, rays, options, probe_directions(options));
}

LeakReport fix_leaks(LightmapTexels& texels, const RayQuery& rays, const LeakOptions& options,
                     const bake::StopCheck& stop, const std::vector<uint8_t>* probe) {
  check(options);
  LeakReport report;
  const size_t n = texels.samples.size();
  if (probe && probe->size() != n)
    throw std::invalid_argument("leak handling: a probe mask of " + std::to_string(probe->size()) + " entries for " +
                                std::to_string(n) + " samples");
  // Results for the probed samples only: the mask prunes most of a large scene's.
  std::vector<uint32_t> probed;
  for (size_t j = 0; j < n; ++j) {
    if (!probe || (*probe)[j]) probed.push_back(static_cast<uint32_t>(j));
  }
  std::vector<LeakResult> results;
  bake::resize_polled(results, probed.size(), stop);
  const std::vector<Vec3> directions = probe_directions(options);
  // Polled every 256 samples (~10^4 rays, a few milliseconds): inside the body, since TBB's partitioner hands one
  // body far more than the grain.
  tbb::parallel_for(tbb::blocked_range<size_t>(0, probed.size(), 256), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t i = range.begin(); i != range.end(); ++i) {
      if ((i - range.begin()) % 256 == 0) stop.check();
      results[i] = resolve(texels.samples[probed[i]], rays, options, directions);
    }
  });

  const size_t valid_before = texels.valid_count();
  std::vector<uint8_t> keep;
  // A sample moved or dropped marks itself first; its texel's other samples are marked below.
  for (size_t i = 0; i < probed.size(); ++i) {
    TexelSample& sample = texels.samples[probed[i]];
    report.rays += results[i].rays;
    switch (results[i].verdict) {
      case LeakVerdict::clear:
        break;
      case LeakVerdict::moved:
        sample.position = results[i].position;
        sample.leak_fixed = true;
        ++report.moved;
        break;
      case LeakVerdict::invalid:
        if (keep.empty()) keep.assign(n, 1);
        keep[probed[i]] = 0;
        sample.leak_fixed = true;
        ++report.invalidated;
        break;
    }
  }
  report.samples = n;
  report.pruned = n - probed.size();
  for (size_t t = 0; t < texels.texel_count(); ++t) {
    const std::span<TexelSample> texel(texels.samples.data() + texels.first[t], texels.first[t + 1] - texels.first[t]);
    if (std::any_of(texel.begin(), texel.end(), [](const TexelSample& s) { return s.leak_fixed; })) {
      for (TexelSample& s : texel) s.leak_fixed = true;
    }
  }
  if (report.invalidated > 0) texels.retain(keep);
  report.texels_invalidated = valid_before - texels.valid_count();
  return report;
}

}  // namespace kiln::lightmap
