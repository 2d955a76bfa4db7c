#include "bakers/lightmap/lightmap_image.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "bakers/bake/number_format.h"
#include "bakers/lightmap/dilate.h"
#include "bakers/scene/lights.h"

namespace kiln::lightmap {
namespace {

// Doubles beyond the float range would become infinities in the file.
float to_float(double v) {
  constexpr double kMax = std::numeric_limits<float>::max();
  return static_cast<float>(std::clamp(v, -kMax, kMax));
}

image::FloatImage blank(const LightmapImage& lm, int channels, std::vector<std::string> names) {
  image::FloatImage img;
  img.width = lm.width();
  img.height = lm.height();
  img.channels = channels;
  img.channel_names = std::move(names);
  img.pixels.assign(lm.texel_count() * channels, 0.0f);
  return img;
}

}  // namespace

LightmapImage::LightmapImage(std::string name, int width, int height, std::vector<uint8_t> validity)
    : name_(std::move(name)), width_(width), height_(height), validity_(std::move(validity)) {
  if (width < 1 || height < 1 || validity_.size() != static_cast<size_t>(width) * static_cast<size_t>(height)) {
    throw std::invalid_argument("lightmap '" + name_ + "': a " + std::to_string(width) + "x" + std::to_string(height) +
                                " image needs a validity map of that many texels, got " +
                                std::to_string(validity_.size()));
  }
  sum_.assign(validity_.size(), Rgb{});
  sum_y2_.assign(validity_.size(), 0.0);
  count_.assign(validity_.size(), 0);
}

double standard_error_of_mean(double sum, double sum_sq, uint32_t n) {
  const double mean = sum / n;
  // Σ y² − n ȳ² can come out a few ulps negative for values that are all equal.
  const double variance = std::max(0.0, (sum_sq - n * mean * mean) / (n - 1));
  return std::sqrt(variance / n);
}

bool LightmapImage::acceptable(const Rgb& e) { return e.is_finite() && e.min() >= 0; }

bool LightmapImage::add(size_t texel, const Rgb& e) {
  if (!valid(texel) || !acceptable(e)) return false;
  const double y = luminance(e);
  merge(texel, e, y * y, 1);
  return true;
}

void LightmapImage::merge(size_t texel, const Rgb& sum, double sum_y2, uint32_t count) {
  if (!valid(texel) || count == 0) return;
  sum_[texel] += sum;
  sum_y2_[texel] += sum_y2;
  count_[texel] += count;
}

Rgb LightmapImage::mean(size_t texel) const { return count_[texel] > 0 ? sum_[texel] / count_[texel] : Rgb{}; }

double LightmapImage::relative_error(size_t texel, double floor) const {
  if (!valid(texel)) return 0;
  const uint32_t n = count_[texel];
  if (n < 2) return std::numeric_limits<double>::infinity();
  const double mean_y = luminance(sum_[texel]) / n;
  const double standard_error = standard_error_of_mean(luminance(sum_[texel]), sum_y2_[texel], n);
  const double denominator = std::max(mean_y, floor);
  // All estimates 0 (non-negative ones with a zero mean): no light reaches the texel, and that is exact.
  if (!(denominator > 0)) return 0;
  return standard_error / denominator;
}

LightmapImage::ErrorSummary LightmapImage::error_summary(double target, double floor) const {
  ErrorSummary s;
  double sum_sq = 0;
  for (size_t t = 0; t < texel_count(); ++t) {
    s.estimates += count_[t];
    if (!valid(t)) continue;
    ++s.valid;
    const double e = relative_error(t, floor);
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

image::FloatImage LightmapImage::irradiance_image(int padding) const {
  image::FloatImage img = blank(*this, 3, {"R", "G", "B"});
  for (size_t t = 0; t < texel_count(); ++t) {
    if (!valid(t)) continue;
    const Rgb m = mean(t);
    for (int c = 0; c < 3; ++c) img.pixels[t * 3 + c] = to_float(m[c]);
  }
  dilate(img, validity_, padding);
  return img;
}

image::FloatImage LightmapImage::validity_image() const {
  image::FloatImage img = blank(*this, 1, {"Y"});
  for (size_t t = 0; t < texel_count(); ++t) img.pixels[t] = valid(t) ? 1.0f : 0.0f;
  return img;
}

image::FloatImage LightmapImage::error_image(double floor) const {
  image::FloatImage img = blank(*this, 1, {"Y"});
  for (size_t t = 0; t < texel_count(); ++t) {
    const double e = relative_error(t, floor);
    img.pixels[t] = std::isfinite(e) ? to_float(e) : 1.0f;  // no estimate yet: reported as 100 %
  }
  return img;
}

std::vector<bake::BakeOutput> encode_lightmap(const LightmapImage& lm, const LightmapOutputOptions& options) {
  if (options.padding < 0 || options.padding > 64) {
    throw std::invalid_argument("lightmap '" + lm.name() + "': padding must be in [0, 64] texels, got " +
                                std::to_string(options.padding));
  }
  if (!(options.error_floor >= 0) || !std::isfinite(options.error_floor)) {
    throw std::invalid_argument("lightmap '" + lm.name() + "': error_floor must be finite and >= 0 W/m^2, got " +
                                bake::format_number(options.error_floor));
  }
  const auto common = [&](image::FloatImage& img, const char* content, const char* units, const std::string& space) {
    img.metadata["kiln:content"] = content;
    img.metadata["kiln:units"] = units;
    img.metadata["kiln:colorspace"] = space;
    img.metadata["kiln:lightmap"] = lm.name();
    img.metadata["kiln:resolution"] = std::to_string(lm.width()) + "x" + std::to_string(lm.height());
    img.metadata["kiln:uv_convention"] = kLightmapUvConvention;
  };

  image::FloatImage irradiance = lm.irradiance_image(options.padding);
  common(irradiance, "irradiance", "W/m^2", options.color_space);
  irradiance.metadata["kiln:padding"] = std::to_string(options.padding);

  image::FloatImage validity = lm.validity_image();
  common(validity, "validity", "1 valid, 0 invalid (before dilation)", "data");

  image::FloatImage error = lm.error_image(options.error_floor);
  common(error, "relative error", "standard error of the mean luminance / max(mean luminance, floor)", "data");
  error.metadata["kiln:error_floor"] = bake::format_number(options.error_floor);

  std::vector<bake::BakeOutput> out;
  out.push_back({lm.name() + "_irradiance.exr", "image/x-exr", "scene_linear", image::encode_exr(irradiance)});
  out.push_back({lm.name() + "_validity.exr", "image/x-exr", "data", image::encode_exr(validity)});
  out.push_back({lm.name() + "_error.exr", "image/x-exr", "data", image::encode_exr(error)});
  return out;
}

}  // namespace kiln::lightmap
