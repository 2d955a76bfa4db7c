#include "bakers/lightmap/lightmap_results.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "bakers/lightmap/dilate.h"

namespace kiln::lightmap {
namespace {

// Doubles beyond the float range would become infinities in the file.
float to_float(double v) {
  constexpr double kMax = std::numeric_limits<float>::max();
  return static_cast<float>(std::clamp(v, -kMax, kMax));
}

image::FloatImage blank(const LightmapResults& lm, int channels, std::vector<std::string> names) {
  image::FloatImage img;
  img.width = lm.width();
  img.height = lm.height();
  img.channels = channels;
  img.channel_names = std::move(names);
  img.pixels.assign(lm.texel_count() * channels, 0.0f);
  return img;
}

}  // namespace

LightmapResults::LightmapResults(std::string name, int width, int height, const ResultChannels& channels)
    : name_(std::move(name)), width_(width), height_(height), channels_(channels) {
  if (width < 1 || height < 1) {
    throw std::invalid_argument("lightmap '" + name_ + "': a page needs a positive size, got " +
                                std::to_string(width) + "x" + std::to_string(height));
  }
  const size_t n = static_cast<size_t>(width) * static_cast<size_t>(height);
  validity_.assign(n, 0);
  mean_.assign(n, Rgb{});
  standard_error_.assign(n, 0.0);
  count_.assign(n, 0);
  if (channels.ao) ao.assign(n, 0.0f);
  if (channels.directional) {
    sh.assign(n, {});
    sh_error.assign(n, 0.0);
  }
  if (channels.radiance) radiance.assign(n, {});
  if (channels.guides) {
    guides.width = width;
    guides.height = height;
    guides.valid.assign(n, 0);
    guides.position.assign(n, Vec3{});
    guides.normal.assign(n, Vec3{});
    guides.texel_size.assign(n, 0.0);
    guides.chart.assign(n, 0);
  }
}

size_t LightmapResults::bytes_per_texel(const ResultChannels& c) {
  size_t b = sizeof(uint8_t) + sizeof(Rgb) + sizeof(double) + sizeof(uint32_t);
  if (c.ao) b += sizeof(float);
  if (c.directional) b += sizeof(std::array<float, 12>) + sizeof(double);
  if (c.radiance) b += sizeof(std::array<float, 3>);
  if (c.guides) b += sizeof(uint8_t) + 2 * sizeof(Vec3) + sizeof(double) + sizeof(uint32_t);
  return b;
}

void LightmapResults::set(size_t texel, bool valid, const Rgb& mean, double standard_error, uint32_t count) {
  validity_[texel] = valid ? 1 : 0;
  mean_[texel] = mean;
  standard_error_[texel] = standard_error;
  count_[texel] = count;
}

double LightmapResults::brightness() const { return mean_brightness(*this); }

double LightmapResults::error(size_t texel, ErrorMetric metric, double brightness, double floor) const {
  if (!valid(texel)) return 0;
  return relative_error_of(standard_error(texel), luminance(mean(texel)), metric, brightness, floor);
}

LightmapImage::ErrorSummary LightmapResults::error_summary(double target, double floor, ErrorMetric metric) const {
  return summarize_errors(*this, brightness(), target, floor, metric);
}

image::FloatImage LightmapResults::irradiance_image(int padding, const bake::StopCheck& stop) const {
  image::FloatImage img = blank(*this, 3, {"R", "G", "B"});
  for (size_t t = 0; t < texel_count(); ++t) {
    if (!valid(t)) continue;
    const Rgb m = mean(t);
    for (int c = 0; c < 3; ++c) img.pixels[t * 3 + c] = to_float(m[c]);
  }
  dilate(img, validity_, padding, stop);
  return img;
}

image::FloatImage LightmapResults::validity_image() const {
  image::FloatImage img = blank(*this, 1, {"Y"});
  for (size_t t = 0; t < texel_count(); ++t) img.pixels[t] = valid(t) ? 1.0f : 0.0f;
  return img;
}

image::FloatImage LightmapResults::error_image(double floor, ErrorMetric metric) const {
  image::FloatImage img = blank(*this, 1, {"Y"});
  const double b = metric == ErrorMetric::lightmap ? brightness() : 0.0;
  for (size_t t = 0; t < texel_count(); ++t) {
    const double e = error(t, metric, b, floor);
    img.pixels[t] = std::isfinite(e) ? to_float(e) : 1.0f;  // no estimate yet: reported as 100 %
  }
  return img;
}

LightmapResults results_of(const LightmapImage& image) {
  LightmapResults r(image.name(), image.width(), image.height(), {});
  for (size_t t = 0; t < image.texel_count(); ++t) {
    r.set(t, image.valid(t), image.mean(t), image.standard_error(t), image.count(t));
  }
  return r;
}

}  // namespace kiln::lightmap
