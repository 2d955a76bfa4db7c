// How a time-limited tiled bake divides its limit. Once its sampling ends the bake still has work no limit can skip:
// the tiles it did not sample are rasterized (their texels' validity and guides) and every page not yet written is
// dilated, stitched, encoded and streamed out. On a level that work is most of a short limit, so the budget holds it
// back from the sampling, forecast from the rates the bake has measured so far:
//
//   after(C, P) = r_u·C + r_o·P
//
// for tiles covering C texels² still to be rasterized and pages of P texels still to be written, r_u the seconds a
// texel² of an unsampled tile takes (rasterized at one point per texel, its state made and its results collected)
// and r_o a page texel's outputs. A sampled tile but for its passes (rasterized at four points per texel, its leak
// probes, state and results) costs r_s a texel², and its first pass, which gives each texel its first min_samples
// estimates, r_1.
//
// With L seconds left, a tile of coverage c followed by tiles of coverage C and pages of P texels has the spare time
// X = L − after(c + C, P) beyond what must be done anyway, and sampling it costs (r_s − r_u)·c more than not:
// - it is sampled when X covers that and its first pass, X ≥ (r_s − r_u + r_1)·c: a tile set up and cut short in its
//   first pass leaves texels without estimates for the set-up's price, and estimates for more texels lower the bake's
//   error more than more estimates for fewer. Once rasterized, the tile is asked again, with the rasterization's rate
//   measured, before its probes: the bake's first tile is chosen on the outputs' prior alone;
// - once set up, with X′ = L − after(C, P) left beyond what must follow it: when every tile after it can be sampled
//   with at least a first pass, X′ − (r_s − r_u)·C ≥ r_1·(c + C), it samples for its share of what their set-ups
//   leave, (X′ − (r_s − r_u)·C)·c / (c + C), the share of the UV area it covers (TileBins::coverage), as the untiled
//   passes give every texel the same time; otherwise for its first pass, r_1·c, or what X′ allows, and the tiles after
//   it get what is left.
//
// The rates are measured, each a total of seconds over a total of work; before a rate has been measured it is
// forecast from priors (the constants below), and the forecast corrects itself as the tiles and pages go by. The
// priors of a sampled tile's stages are multiples of its rasterization, the first stage measured: before any tile
// is rasterized they are 0 and the bake's first tile is chosen on the outputs' prior alone; once it is, its probes
// and first pass are forecast from its rasterization until measured, so that a tile whose probes and first pass
// cannot fit is not probed, and a tile that cannot have its share gets its first pass as forecast.
#pragma once

namespace kiln::lightmap {

// An unsampled tile against a sampled tile's rasterization, per texel² covered, until one has been measured: a quarter
// of the points, with its state and results besides (0.19 measured on the generated level, docs/PERFORMANCE.md).
inline constexpr double kUnsampledRasterShare = 0.25;
// A sampled tile's leak probes and its first pass against its rasterization, per texel² covered, until measured:
// about 3 and 7 on the generated level (docs/PERFORMANCE.md), where a tile's probes (~9 s a 1024² tile) and first
// pass (~20 s) are what a short limit cannot afford.
inline constexpr double kProbesRasterShare = 3;
inline constexpr double kFirstPassRasterShare = 7;
// A page texel's outputs (dilation, seams, encoding, preview), seconds, until a page has been written: twice the
// 0.52 µs measured on the generated level's 2048² pages (docs/PERFORMANCE.md), and the denoiser's 1.1 µs on top when
// it runs.
inline constexpr double kOutputSecondsPerTexel = 1.0e-6;
inline constexpr double kDenoiseSecondsPerTexel = 1.1e-6;

// Seconds per unit of work (texel² covered, page texel), summed over what was measured.
class StageRate {
 public:
  void add(double seconds, double amount);
  bool measured() const { return amount_ > 0; }
  // The measured rate, or `prior` before any measurement.
  double per_unit(double prior) const { return measured() ? seconds_ / amount_ : prior; }

 private:
  double seconds_ = 0, amount_ = 0;
};

// Where a tile stands when the budget is asked about it: `left` seconds to the limit, the tile covering `coverage`
// texels², the tiles after it `coverage_after`, and the pages still to be written `page_texels` (its own included).
struct TileOutlook {
  double left = 0;
  double coverage = 0;
  double coverage_after = 0;
  double page_texels = 0;
};

class TileTimeBudget {
 public:
  explicit TileTimeBudget(bool denoise)
      : output_prior_(kOutputSecondsPerTexel + (denoise ? kDenoiseSecondsPerTexel : 0)) {}

  // What the bake measured, each with its coverage (texels²) or its texels: a sampled tile's rasterization, its leak
  // probes, its first pass (over the coverage it reached: the tile's times the share of its texels that got
  // estimates, when the pass was cut short) and the rest of it (its state made, its results collected); an unsampled
  // tile, whole; a page's outputs.
  void sampled_raster(double seconds, double coverage) { sampled_raster_.add(seconds, coverage); }
  void probes(double seconds, double coverage) { probes_.add(seconds, coverage); }
  void first_pass(double seconds, double coverage) { first_pass_.add(seconds, coverage); }
  void sampled_rest(double seconds, double coverage) { sampled_rest_.add(seconds, coverage); }
  void unsampled_tile(double seconds, double coverage) { unsampled_.add(seconds, coverage); }
  void page_written(double seconds, double page_texels) { outputs_.add(seconds, page_texels); }

  // The forecast of what follows the sampling, after(C, P) above, in seconds.
  double after(double coverage, double page_texels) const;
  // Whether the tile should be sampled.
  bool should_sample(const TileOutlook& o) const;
  // The same asked again once the tile is rasterized, with the rate of rasterization measured: whether what is left
  // covers its probes and first pass beside what must follow it (the bake's first tile is chosen on the outputs'
  // prior alone).
  bool should_probe(const TileOutlook& o) const;
  // The seconds the tile samples for, its set-up done.
  double sampling_seconds(const TileOutlook& o) const;

  // The rates as forecast now, seconds per texel² covered: a sampled tile but for its passes (rasterization, probes,
  // state and results), its first pass, an unsampled tile; and seconds per page texel for the outputs.
  double sampled_rate() const { return sampled_raster_.per_unit(0) + probes_rate() + sampled_rest_.per_unit(0); }
  double probes_rate() const { return probes_.per_unit(kProbesRasterShare * sampled_raster_.per_unit(0)); }
  double first_pass_rate() const { return first_pass_.per_unit(kFirstPassRasterShare * sampled_raster_.per_unit(0)); }
  double unsampled_rate() const;
  double output_rate() const { return outputs_.per_unit(output_prior_); }

 private:
  StageRate sampled_raster_, probes_, first_pass_, sampled_rest_, unsampled_, outputs_;
  double output_prior_;
};

}  // namespace kiln::lightmap
