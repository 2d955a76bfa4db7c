// One lightmap's results once its texels are sampled: per texel what the output images are made of — validity, the
// mean irradiance, the standard error of its luminance and the estimate count (37 bytes), and on request the AO
// (4), the SH coefficients and their error (56), the diffuse radiance (12) and the denoiser's guides (61) — instead
// of the ~900 bytes a texel holds while it is sampled (its sample points, replica sums). A tiled bake
// (lightmap_bake.cpp) copies each tile's results in and frees the tile, so only this stays for a whole page; an
// untiled bake copies its whole page in at once. The images (and lightmap_outputs.h's) are made from it.
//
// The means and errors are kept in double, as the sampling state holds them, so that the images do not depend on
// whether the page was baked in tiles or whole, beyond the estimates themselves.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "bakers/bake/output.h"
#include "bakers/bake/stop.h"
#include "bakers/image/exr.h"
#include "bakers/lightmap/denoise.h"
#include "bakers/lightmap/lightmap_image.h"
#include "bakers/math/rgb.h"

namespace kiln::lightmap {

// Which optional per-texel results a page keeps (the outputs asked for).
struct ResultChannels {
  bool ao = false;
  bool directional = false;
  bool radiance = false;
  bool guides = false;  // the denoiser's (texel_guides.h)
};

// The channels for the outputs a job asks for: `outputs` is anything with the flags ao, directional, radiance and
// denoise (a bake's input, or the job size a memory estimate is made from).
template <class Outputs>
ResultChannels result_channels(const Outputs& outputs) {
  return ResultChannels{outputs.ao, outputs.directional, outputs.radiance, outputs.denoise};
}

class LightmapResults {
 public:
  // Every texel invalid until set.
  LightmapResults(std::string name, int width, int height, const ResultChannels& channels);

  // The page bytes per texel these channels hold.
  static size_t bytes_per_texel(const ResultChannels& channels);

  const std::string& name() const { return name_; }
  int width() const { return width_; }
  int height() const { return height_; }
  size_t texel_count() const { return validity_.size(); }
  size_t bytes() const { return texel_count() * bytes_per_texel(channels_); }  // what the page's results hold
  const ResultChannels& channels() const { return channels_; }
  bool valid(size_t texel) const { return validity_[texel] != 0; }
  const std::vector<uint8_t>& validity() const { return validity_; }
  Rgb mean(size_t texel) const { return mean_[texel]; }
  double standard_error(size_t texel) const { return standard_error_[texel]; }
  uint32_t count(size_t texel) const { return count_[texel]; }

  // Sets a texel's irradiance results (what LightmapImage says of it).
  void set(size_t texel, bool valid, const Rgb& mean, double standard_error, uint32_t count);

  // As LightmapImage's, over this page's texels.
  double brightness() const;
  double error(size_t texel, ErrorMetric metric, double brightness, double floor = 0) const;
  LightmapImage::ErrorSummary error_summary(double target, double floor = 0,
                                            ErrorMetric metric = ErrorMetric::texel) const;

  // The resolved images. Irradiance: the means (invalid texels 0), then dilated by `padding` texels (dilate.h).
  // Validity: 1/0, before dilation. Error: error() under `metric` (invalid 0, unestimated 1). One channel except
  // irradiance. Every value is finite (means beyond the float range are clamped to its largest value).
  image::FloatImage irradiance_image(int padding, const bake::StopCheck& stop = {}) const;
  image::FloatImage validity_image() const;
  image::FloatImage error_image(double floor = 0, ErrorMetric metric = ErrorMetric::texel) const;

  // The optional channels, per texel, allocated when asked for (ResultChannels); set by collect_results
  // (lightmap_outputs.h).
  std::vector<float> ao;                      // the mean AO estimate
  std::vector<std::array<float, 12>> sh;      // the mean SH coefficients, L00 L1m1 L10 L11, RGB each
  std::vector<double> sh_error;               // their estimated relative error (+∞ below two estimates)
  std::vector<std::array<float, 3>> radiance;  // ρE/π
  TexelGuides guides;                         // the denoiser's guides; its `valid` is the page's validity

 private:
  std::string name_;
  int width_ = 0, height_ = 0;
  ResultChannels channels_;
  std::vector<uint8_t> validity_;
  std::vector<Rgb> mean_;
  std::vector<double> standard_error_;
  std::vector<uint32_t> count_;
};

// The results of an image alone (no optional channels): its means, errors and counts.
LightmapResults results_of(const LightmapImage& image);

}  // namespace kiln::lightmap
