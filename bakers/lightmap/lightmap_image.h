// One lightmap's estimates as they accumulate: per texel the sum of the irradiance estimates (RGB), their count and
// their luminance summed per replica (replica_sums.h), so that the transport can tell where the estimated error is
// still above its target; then resolved into the output images NAME_irradiance.exr (RGB, W·m⁻², dilated),
// NAME_validity.exr (1 valid, 0 invalid, before dilation) and NAME_error.exr (estimated relative error).
//
// The error of a texel: its estimates are unbiased (each the weighted average over the texel's sample points of one
// path per point) and fall into kReplicas independently scrambled replicas; the standard error s of the mean
// luminance Ȳ comes from the spread of the replica means (replica_sums.h). The error is s over a luminance chosen by
// the metric (error_metric.h): the lightmap's brightness B (mean luminance of its valid texels) or the texel's own
// Ȳ, in either case at least `floor` (≥ 0, W·m⁻²), which keeps nearly black texels from demanding endless samples.
// With floor 0, a texel whose estimates are all 0 has error 0. A texel with an empty replica (fewer than kReplicas
// estimates) has no error estimate (+∞; the error image says 1).
//
// Texel layout and UV convention as in texels.h (row-major, top row first).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "bakers/bake/output.h"
#include "bakers/bake/stop.h"
#include "bakers/image/exr.h"
#include "bakers/lightmap/error_metric.h"
#include "bakers/lightmap/replica_sums.h"
#include "bakers/math/rgb.h"

namespace kiln::lightmap {

// The kiln:uv_convention of every lightmap image.
inline constexpr const char* kLightmapUvConvention =
    "u right, v down: row 0 (the first row stored) is v = 0, as in glTF; texel (x, y) centre at "
    "((x + 0.5)/W, (y + 0.5)/H)";

// The standard error of the mean of n values from their sum and the sum of their squares: √(s²/n) with the sample
// variance s² = (Σ y² − n ȳ²)/(n − 1); needs n ≥ 2. Shared by the irradiance and the SH error estimates.
double standard_error_of_mean(double sum, double sum_sq, uint32_t n);

class LightmapImage {
 public:
  // validity: width·height bytes (non-zero: valid), e.g. LightmapTexels::validity() after leak handling.
  // Throws std::invalid_argument when the sizes disagree or are not positive.
  LightmapImage(std::string name, int width, int height, std::vector<uint8_t> validity);

  const std::string& name() const { return name_; }
  int width() const { return width_; }
  int height() const { return height_; }
  size_t texel_count() const { return validity_.size(); }
  bool valid(size_t texel) const { return validity_[texel] != 0; }
  const std::vector<uint8_t>& validity() const { return validity_; }

  // Adds one unbiased estimate of the texel's irradiance (W·m⁻²) to replica `replica` (by default the next in turn,
  // count mod kReplicas, as the sampler interleaves them). An estimate with a NaN, infinite or negative channel, or
  // for an invalid texel, is refused (returns false): it must never reach a texel, and the caller counts it for the
  // report. Different texels may be added to from different threads at once; one texel from one thread at a time.
  bool add(size_t texel, const Rgb& estimate, int replica = -1);
  // What add() accepts: every channel finite and non-negative.
  static bool acceptable(const Rgb& estimate);
  // Adds estimates at once, already checked with acceptable(), given by their sum and their replica sums (what a
  // worker accumulates on its own before merging). Ignored for an invalid texel.
  void merge(size_t texel, const Rgb& sum, const ReplicaSums& replicas);
  // Forgets the texel's estimates.
  void reset(size_t texel);

  // A term estimated apart from the texel's estimates and independently of them (light tracing's indirect light,
  // light_tracing.h): its mean and each replica's mean luminance. Every reading of the texel (mean, errors,
  // brightness, images) adds it; each call replaces the last. enable_traced() first, once: it allocates the terms
  // (zero), after which different texels may be set from different threads at once.
  void enable_traced();
  void set_traced(size_t texel, const Rgb& mean, const std::array<double, kReplicas>& replica_luminance);
  void clear_traced(size_t texel);
  // The standard errors of the two parts alone (the texel's own estimates; the traced term, 0 without one).
  double gathered_standard_error(size_t texel) const;
  double traced_standard_error(size_t texel) const;

  // Estimates added to the texel, over its replicas.
  uint32_t count(size_t texel) const { return static_cast<uint32_t>(replicas_[texel].count()); }
  // The mean of the estimates; black without any.
  Rgb mean(size_t texel) const;
  // The standard error of the texel's mean luminance (W·m⁻²): 0 for invalid texels, +∞ without an estimate.
  double standard_error(size_t texel) const;
  // The mean luminance of the valid texels that have estimates (0 if none): the lightmap metric's denominator.
  double brightness() const;
  // The texel's error under `metric` (see the header comment), given the lightmap's brightness; 0 for invalid
  // texels.
  double error(size_t texel, ErrorMetric metric, double brightness, double floor = 0) const;
  // A standard error of the texel (of one of its parts, say) expressed under `metric` as error() does.
  double relative(size_t texel, double standard_error, ErrorMetric metric, double brightness, double floor = 0) const;
  // The texel metric's error, s / max(Ȳ, floor).
  double relative_error(size_t texel, double floor = 0) const { return error(texel, ErrorMetric::texel, 0, floor); }

  struct ErrorSummary {
    size_t valid = 0;         // valid texels
    size_t estimated = 0;     // valid texels with an error estimate
    double rms = 0;           // root mean square of their errors
    double max = 0;           // the largest
    size_t above_target = 0;  // how many are above `target` (plus the valid ones without an estimate)
    uint64_t estimates = 0;   // estimates added over all texels
    double brightness = 0;    // the lightmap's (brightness())
  };
  ErrorSummary error_summary(double target, double floor = 0, ErrorMetric metric = ErrorMetric::texel) const;

  // The lightmap metric's brightness counts, beside this image's texels, `texels` others whose mean luminances sum to
  // `luminance_sum`: the tiles of the page sampled before this one (a tiled bake samples a page a tile at a time,
  // and a tile's brightness alone would set its target by the wrong scale).
  void set_brightness_prior(double luminance_sum, size_t texels) {
    prior_luminance_ = luminance_sum;
    prior_texels_ = texels;
  }

  // Memory held per texel: sum (3 doubles), replica sums (with the counts), validity (byte).
  static constexpr size_t kBytesPerTexel = 3 * sizeof(double) + sizeof(ReplicaSums) + sizeof(uint8_t);
  // And with a traced term: its mean and replicas' luminances.
  static constexpr size_t kTracedBytesPerTexel = sizeof(Rgb) + kReplicas * sizeof(float);

 private:
  std::string name_;
  int width_ = 0, height_ = 0;
  std::vector<uint8_t> validity_;
  std::vector<Rgb> sum_;
  std::vector<ReplicaSums> replicas_;
  // Light tracing's term, allocated at the first set_traced.
  std::vector<Rgb> traced_;
  std::vector<std::array<float, kReplicas>> traced_y_;
  double prior_luminance_ = 0;
  size_t prior_texels_ = 0;

  ReplicaSums with_traced(size_t texel) const;
  Rgb gathered_mean(size_t texel) const;
};

// What LightmapImage and LightmapResults (lightmap_results.h) read alike, over any T with texel_count(), valid(t),
// count(t), mean(t) and standard_error(t).

// A standard error under `metric`, as LightmapImage::relative says: s / max(Ȳ or the brightness, floor); +∞ for
// an infinite s; 0 when that denominator is 0.
double relative_error_of(double standard_error, double mean_luminance, ErrorMetric metric, double brightness,
                         double floor);

// The mean luminance of the valid texels with estimates, counting `prior_texels` others of luminance sum
// `prior_luminance` (LightmapImage::set_brightness_prior); 0 if none.
template <class T>
double mean_brightness(const T& texels, double prior_luminance = 0, size_t prior_texels = 0) {
  double sum = 0;
  size_t n = 0;
  for (size_t t = 0; t < texels.texel_count(); ++t) {
    if (!texels.valid(t) || texels.count(t) == 0) continue;
    sum += luminance(texels.mean(t));
    ++n;
  }
  sum += prior_luminance;
  n += prior_texels;
  return n > 0 ? sum / n : 0.0;
}

template <class T>
LightmapImage::ErrorSummary summarize_errors(const T& texels, double brightness, double target, double floor,
                                             ErrorMetric metric) {
  LightmapImage::ErrorSummary s;
  s.brightness = brightness;
  double sum_sq = 0;
  for (size_t t = 0; t < texels.texel_count(); ++t) {
    s.estimates += texels.count(t);
    if (!texels.valid(t)) continue;
    ++s.valid;
    const double e = relative_error_of(texels.standard_error(t), luminance(texels.mean(t)), metric, brightness, floor);
    if (!std::isfinite(e)) {
      ++s.above_target;
      continue;
    }
    ++s.estimated;
    sum_sq += e * e;
    s.max = std::max(s.max, e);
    if (e > target) ++s.above_target;
  }
  s.rms = s.estimated > 0 ? std::sqrt(sum_sq / s.estimated) : 0;
  return s;
}
// What an output does to its image after dilation and before encoding (seam stitching, seams.h); empty: nothing.
using ImageFinish = std::function<void(image::FloatImage&)>;

struct LightmapOutputOptions {
  int padding = 2;                          // texels of dilation in NAME_irradiance.exr, [0, 64]
  double error_floor = 0;                   // see LightmapImage; W·m⁻²
  ErrorMetric metric = ErrorMetric::texel;  // of the error image
  std::string color_space = "lin_rec709";   // the working space the irradiance is in (recorded in the metadata)
  const bake::StopCheck* stop = nullptr;    // polled by the dilation (dilate.h); null: never stops
  ImageFinish finish;                       // applied to NAME_irradiance.exr after its dilation
};

// The three files, named NAME_irradiance.exr, NAME_validity.exr, NAME_error.exr, as 32-bit float EXR (ZIP) with
// metadata: kiln:content, kiln:units, kiln:colorspace, kiln:lightmap, kiln:resolution ("WxH"), kiln:uv_convention,
// and kiln:padding / kiln:error_floor / kiln:error_metric / kiln:brightness where they apply. Throws
// std::invalid_argument for a padding out of range or a negative or non-finite floor.
std::vector<bake::BakeOutput> encode_lightmap(const LightmapImage& image, const LightmapOutputOptions& options);
class LightmapResults;
std::vector<bake::BakeOutput> encode_lightmap(const LightmapResults& results, const LightmapOutputOptions& options);

}  // namespace kiln::lightmap
