// A volume of light probes baked to a target error (docs/PROBES.md): placed near geometry (probe_placement.h), then
// sampled in rounds, as the lightmap's texels are: every probe to min_samples, then each probe whose error is above
// the target doubles its estimates, up to max_samples, until none is left or the deadline. A probe's error is the
// standard error of its DC term's luminance divided by the mean DC luminance of the valid probes (ErrorMetric
// lightmap) or by its own (texel). Probes found inside geometry stop sampling once found.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "bakers/bake/invalid_input.h"
#include "bakers/bake/stop.h"
#include "bakers/lightmap/adaptive_sampler.h"
#include "bakers/lightmap/irradiance_probes.h"
#include "bakers/lightmap/probe_placement.h"
#include "proto/bounds.h"

namespace kiln::lightmap {

// A job's probe settings (ProbeVolume in kiln.proto).
struct ProbeVolumeOptions {
  std::vector<ProbeBox> regions;  // empty: the triangles' bounding box grown by max_distance
  double spacing = 0;             // 0: no probes
  double max_distance = -1;       // < 0: 2 × spacing
  uint64_t max_probes = bounds::kDefaultMaxProbes;
  bool preview = true;  // probes_preview.png

  bool enabled() const { return spacing > 0; }
  double distance() const { return max_distance < 0 ? 2 * spacing : max_distance; }
};

// nullopt if valid, else the offending field ("probes.spacing", "probes.regions[2].hi") and what is wrong.
std::optional<bake::InvalidInput> validate(const ProbeVolumeOptions& options);

// The texels' stopping rule (target error and metric, min and max samples, seed, deadline; `directional` unused),
// a cancel flag and a progress callback.
struct ProbeSamplingOptions {
  SamplingOptions stopping;
  const std::atomic<bool>* cancel = nullptr;
  std::function<void(double fraction, double error)> progress;  // after each round: probes done, RMS error
};

struct ProbeVolumeResult {
  ProbePlacement placement;
  std::vector<ProbeSummary> probes;    // per placed probe
  std::vector<double> relative_error;  // per placed probe, under the metric; 0 for invalid ones
  std::vector<uint64_t> samples_per_probe;
  double brightness = 0;  // the mean DC luminance of the valid probes
  uint64_t samples = 0, rays = 0, dropped = 0;
  size_t valid = 0, invalid = 0, above_target = 0;
  double rms_error = -1, max_error = -1;  // over the valid probes; −1 when there are none
  int rounds = 0;
  bool out_of_time = false;  // the deadline ended the sampling
  double placement_seconds = 0, sampling_seconds = 0;
  ProbeSamplingOptions sampling;
  ProbeVolumeOptions options;
};

// Places the probes (`stop` polled, its OutOfTime and BakeCancelled passed on) and samples them.
ProbeVolumeResult bake_probe_volume(const TransportContext& ctx, const ProbeVolumeOptions& options,
                                    const ProbeSamplingOptions& sampling, const bake::StopCheck& stop);

}  // namespace kiln::lightmap
