#include "bakers/lightmap/probe_volume.h"

#include <algorithm>
#include <cmath>

#include <tbb/parallel_for.h>

#include "bakers/bake/cancelled.h"
#include "bakers/bake/number_format.h"
#include "bakers/bake/range_check.h"

namespace kiln::lightmap {
namespace {

using Clock = std::chrono::steady_clock;

std::optional<bake::InvalidInput> check_box(const ProbeBox& b, const std::string& field) {
  const double lo[3] = {b.lo.x, b.lo.y, b.lo.z}, hi[3] = {b.hi.x, b.hi.y, b.hi.z};
  const char* axes[3] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a) {
    if (auto e = bake::check_range(field + ".lo." + axes[a], lo[a], bounds::kProbeCoordinate)) return e;
    if (auto e = bake::check_range(field + ".hi." + axes[a], hi[a], bounds::kProbeCoordinate)) return e;
    // A box flat along an axis (or inverted) holds no volume to fill with probes.
    if (!(lo[a] < hi[a])) {
      return bake::InvalidInput(field + ".hi", std::string("must be above lo on every axis (a region holds a volume), "
                                                           "got ") +
                                                   axes[a] + " from " + bake::format_number(lo[a]) + " to " +
                                                   bake::format_number(hi[a]));
    }
  }
  return std::nullopt;
}

// The relative error of every probe under the metric, and the brightness it is relative to.
double relative_errors(ProbeVolumeResult& r) {
  double sum = 0;
  size_t n = 0;
  for (const ProbeSummary& p : r.probes) {
    if (!p.valid) continue;
    sum += p.dc_luminance;
    ++n;
  }
  r.brightness = n ? sum / static_cast<double>(n) : 0.0;
  for (size_t i = 0; i < r.probes.size(); ++i) {
    const ProbeSummary& p = r.probes[i];
    const double ref = r.sampling.stopping.metric == ErrorMetric::texel ? p.dc_luminance : r.brightness;
    // A black reference (no light reaches it): the error is 0 when every estimate was 0, else unbounded.
    r.relative_error[i] = !p.valid ? 0.0 : ref > 0 ? p.error / ref : (p.error > 0 ? HUGE_VAL : 0.0);
  }
  return r.brightness;
}

void tally(ProbeVolumeResult& r) {
  r.valid = r.invalid = r.above_target = 0;
  double sum2 = 0, most = 0;
  for (size_t i = 0; i < r.probes.size(); ++i) {
    if (!r.probes[i].valid) {
      ++r.invalid;
      continue;
    }
    ++r.valid;
    const double e = r.relative_error[i];
    r.above_target += e > r.sampling.stopping.target_error;
    if (!std::isfinite(e)) continue;  // unknown (a black reference): counted above the target, not in the RMS
    sum2 += e * e;
    most = std::max(most, e);
  }
  r.rms_error = r.valid ? std::sqrt(sum2 / static_cast<double>(r.valid)) : -1;
  r.max_error = r.valid ? most : -1;
}

// The estimates each probe is to reach this round: min_samples first, then double for those above the target.
std::vector<uint64_t> round_targets(const ProbeVolumeResult& r) {
  std::vector<uint64_t> to(r.probes.size());
  const ProbeSamplingOptions& o = r.sampling;
  for (size_t i = 0; i < to.size(); ++i) {
    const uint64_t have = r.samples_per_probe[i];
    if (r.rounds == 0) {
      to[i] = o.stopping.min_samples;
    } else {
      const bool more =
          r.probes[i].valid && r.relative_error[i] > o.stopping.target_error && have < o.stopping.max_samples;
      to[i] = more ? std::min(o.stopping.max_samples, 2 * have) : have;
    }
  }
  return to;
}

// One round; false when no probe asked for more. The first round runs whatever the deadline, so every probe has
// min_samples; later ones leave a probe as it is once the deadline has passed.
bool sample_round(const TransportContext& ctx, std::vector<ProbeSums>& sums, ProbeVolumeResult& r) {
  const std::vector<uint64_t> to = round_targets(r);
  bool any = false;
  for (size_t i = 0; i < to.size(); ++i) any |= to[i] > r.samples_per_probe[i];
  if (!any) return false;
  const bool first = r.rounds == 0;
  tbb::parallel_for(size_t{0}, to.size(), [&](size_t i) {
    if (to[i] <= r.samples_per_probe[i]) return;
    if (r.sampling.cancel && r.sampling.cancel->load(std::memory_order_relaxed)) return;
    if (!first && Clock::now() >= r.sampling.stopping.deadline) return;
    sample_probe(ctx, r.placement.positions[i], i, r.sampling.stopping.seed, r.samples_per_probe[i], to[i], sums[i]);
    r.probes[i] = summarize_probe(sums[i]);
    r.samples_per_probe[i] = to[i];
  });
  if (r.sampling.cancel && r.sampling.cancel->load()) throw bake::BakeCancelled();
  ++r.rounds;
  return true;
}

}  // namespace

std::optional<bake::InvalidInput> validate(const ProbeVolumeOptions& o) {
  if (auto e = bake::check_range("probes.spacing", o.spacing, bounds::kProbeSpacing)) return e;
  if (o.max_distance >= 0 || std::isnan(o.max_distance)) {
    if (auto e = bake::check_range("probes.max_distance", o.max_distance, bounds::kProbeMaxDistance)) return e;
  }
  if (auto e = bake::check_range("probes.max_probes", static_cast<double>(o.max_probes), bounds::kProbeCount.real()))
    return e;
  if (auto e = bake::check_range("probes.regions", static_cast<double>(o.regions.size()), bounds::kProbeRegions.real()))
    return e;
  for (size_t i = 0; i < o.regions.size(); ++i) {
    if (auto e = check_box(o.regions[i], "probes.regions[" + std::to_string(i) + "]")) return e;
  }
  return std::nullopt;
}

ProbeVolumeResult bake_probe_volume(const TransportContext& ctx, const ProbeVolumeOptions& options,
                                    const ProbeSamplingOptions& sampling, const bake::StopCheck& stop) {
  ProbeVolumeResult r;
  r.options = options;
  r.sampling = sampling;
  const Clock::time_point t0 = Clock::now();
  r.placement =
      place_probes(*ctx.scene, {options.regions, options.spacing, options.distance(), options.max_probes}, stop);
  r.placement_seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  const size_t n = r.placement.positions.size();
  r.probes.assign(n, {});
  r.relative_error.assign(n, 0.0);
  r.samples_per_probe.assign(n, 0);
  std::vector<ProbeSums> sums(n);
  while (sample_round(ctx, sums, r)) {
    relative_errors(r);
    tally(r);
    if (sampling.progress) {
      sampling.progress(r.valid ? 1.0 - static_cast<double>(r.above_target) / static_cast<double>(r.valid) : 1.0,
                        r.rms_error);
    }
    if (Clock::now() >= sampling.stopping.deadline) {
      r.out_of_time = r.above_target > 0;
      break;
    }
  }
  relative_errors(r);
  tally(r);
  for (const ProbeSums& s : sums) {
    r.samples += s.taken;
    r.rays += s.rays;
    r.dropped += s.dropped;
  }
  r.sampling_seconds = std::chrono::duration<double>(Clock::now() - t0).count() - r.placement_seconds;
  return r;
}

}  // namespace kiln::lightmap
