#include "bakers/lightmap/tile_time_budget.h"

#include <algorithm>

namespace kiln::lightmap {

void StageRate::add(double seconds, double amount) {
  if (!(seconds >= 0) || !(amount > 0)) return;  // a tile with no coverage, a clock read twice: nothing to learn
  seconds_ += seconds;
  amount_ += amount;
}

double TileTimeBudget::unsampled_rate() const {
  return unsampled_.per_unit(kUnsampledRasterShare * sampled_raster_.per_unit(0));
}

double TileTimeBudget::after(double coverage, double page_texels) const {
  return unsampled_rate() * coverage + output_rate() * page_texels;
}

bool TileTimeBudget::should_sample(const TileOutlook& o) const {
  const double spare = o.left - after(o.coverage + o.coverage_after, o.page_texels);
  const double extra = std::max(0.0, sampled_rate() - unsampled_rate());
  // Before the first tile is set up every rate but the outputs' is 0: sampled if the outputs leave any time.
  return spare > 0 && spare >= (extra + first_pass_rate()) * o.coverage;
}

bool TileTimeBudget::should_probe(const TileOutlook& o) const {
  const double spare = o.left - after(o.coverage_after, o.page_texels);
  return spare > 0 && spare >= (probes_rate() + first_pass_rate()) * o.coverage;
}

double TileTimeBudget::sampling_seconds(const TileOutlook& o) const {
  const double spare = o.left - after(o.coverage_after, o.page_texels);
  if (!(spare > 0)) return 0;
  const double extra = std::max(0.0, sampled_rate() - unsampled_rate());
  const double shared = spare - extra * o.coverage_after;
  const double all = o.coverage + o.coverage_after;
  // Every tile left can be sampled with at least its first pass: the time is shared by UV area. (all > 0 whenever
  // shared ≥ r_1·all holds with r_1 > 0; with no pass measured yet, a tile without coverage takes the spare.)
  if (shared >= first_pass_rate() * all && shared > 0) return all > 0 ? shared * (o.coverage / all) : spare;
  // Not every tile can have a pass: this one gets its first pass, as forecast, or what X′ allows; all of X′ when
  // nothing forecasts a pass (no rasterization measured).
  if (!(first_pass_rate() > 0)) return spare;
  return std::min(spare, first_pass_rate() * o.coverage);
}

}  // namespace kiln::lightmap
