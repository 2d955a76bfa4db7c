#include "bakers/lightmap/lightmap_image.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "bakers/bake/number_format.h"
#include "bakers/lightmap/dilate.h"
#include "bakers/lightmap/lightmap_results.h"
#include "bakers/scene/lights.h"

namespace kiln::lightmap {

LightmapImage::LightmapImage(std::string name, int width, int height, std::vector<uint8_t> validity)
    : name_(std::move(name)), width_(width), height_(height), validity_(std::move(validity)) {
  if (width < 1 || height < 1 || validity_.size() != static_cast<size_t>(width) * static_cast<size_t>(height)) {
    throw std::invalid_argument("lightmap '" + name_ + "': a " + std::to_string(width) + "x" + std::to_string(height) +
                                " image needs a validity map of that many texels, got " +
                                std::to_string(validity_.size()));
  }
  sum_.assign(validity_.size(), Rgb{});
  replicas_.assign(validity_.size(), ReplicaSums{});
}

double standard_error_of_mean(double sum, double sum_sq, uint32_t n) {
  const double mean = sum / n;
  // Σ y² − n ȳ² can come out a few ulps negative for values that are all equal.
  const double variance = std::max(0.0, (sum_sq - n * mean * mean) / (n - 1));
  return std::sqrt(variance / n);
}

bool LightmapImage::acceptable(const Rgb& e) { return e.is_finite() && e.min() >= 0; }

bool LightmapImage::add(size_t texel, const Rgb& e, int replica) {
  if (!valid(texel) || !acceptable(e)) return false;
  ReplicaSums one;
  one.add(replica >= 0 ? replica % kReplicas : static_cast<int>(count(texel) % kReplicas), luminance(e));
  merge(texel, e, one);
  return true;
}

void LightmapImage::merge(size_t texel, const Rgb& sum, const ReplicaSums& replicas) {
  if (!valid(texel) || replicas.count() == 0) return;
  sum_[texel] += sum;
  replicas_[texel].merge(replicas);
}

void LightmapImage::reset(size_t texel) {
  sum_[texel] = Rgb{};
  replicas_[texel] = ReplicaSums{};
}

void LightmapImage::enable_traced() {
  if (!traced_.empty()) return;
  traced_.assign(texel_count(), Rgb{});
  traced_y_.assign(texel_count(), {});
}

void LightmapImage::set_traced(size_t texel, const Rgb& mean, const std::array<double, kReplicas>& replica_luminance) {
  if (traced_.empty()) throw std::logic_error("LightmapImage::set_traced before enable_traced");
  traced_[texel] = mean;
  for (int r = 0; r < kReplicas; ++r) traced_y_[texel][r] = static_cast<float>(replica_luminance[r]);
}

void LightmapImage::clear_traced(size_t texel) {
  if (traced_.empty()) return;
  traced_[texel] = Rgb{};
  traced_y_[texel] = {};
}

// The replica sums as if every estimate carried its replica's traced term: replica r's mean becomes g_r + p_r.
ReplicaSums LightmapImage::with_traced(size_t texel) const {
  ReplicaSums s = replicas_[texel];
  if (traced_.empty()) return s;
  for (int r = 0; r < kReplicas; ++r) s.y[r] += static_cast<double>(traced_y_[texel][r]) * s.n[r];
  return s;
}

Rgb LightmapImage::gathered_mean(size_t texel) const {
  const uint32_t n = count(texel);
  return n > 0 ? sum_[texel] / n : Rgb{};
}

Rgb LightmapImage::mean(size_t texel) const {
  if (count(texel) == 0) return Rgb{};
  return traced_.empty() ? gathered_mean(texel) : gathered_mean(texel) + traced_[texel];
}

double LightmapImage::standard_error(size_t texel) const {
  if (!valid(texel)) return 0;
  return replica_standard_error(with_traced(texel));
}

double LightmapImage::gathered_standard_error(size_t texel) const {
  if (!valid(texel)) return 0;
  return replica_standard_error(replicas_[texel]);
}

double LightmapImage::traced_standard_error(size_t texel) const {
  if (!valid(texel) || traced_.empty()) return 0;
  ReplicaSums s;
  for (int r = 0; r < kReplicas; ++r) {
    s.y[r] = traced_y_[texel][r];
    s.n[r] = 1;
  }
  return replica_standard_error(s);
}

double relative_error_of(double se, double mean_y, ErrorMetric metric, double brightness, double floor) {
  if (!std::isfinite(se)) return std::numeric_limits<double>::infinity();
  const double denominator = std::max(metric == ErrorMetric::texel ? mean_y : brightness, floor);
  // Texel metric, all estimates 0 (non-negative ones with a zero mean): no light reaches the texel, and that is
  // exact. Lightmap metric, a black lightmap: the same for every texel.
  if (!(denominator > 0)) return 0;
  return se / denominator;
}

double LightmapImage::brightness() const { return mean_brightness(*this, prior_luminance_, prior_texels_); }

double LightmapImage::error(size_t texel, ErrorMetric metric, double brightness, double floor) const {
  return relative(texel, standard_error(texel), metric, brightness, floor);
}

double LightmapImage::relative(size_t texel, double se, ErrorMetric metric, double brightness, double floor) const {
  if (!valid(texel)) return 0;
  return relative_error_of(se, luminance(mean(texel)), metric, brightness, floor);
}

LightmapImage::ErrorSummary LightmapImage::error_summary(double target, double floor, ErrorMetric metric) const {
  return summarize_errors(*this, brightness(), target, floor, metric);
}

std::vector<bake::BakeOutput> encode_lightmap(const LightmapImage& lm, const LightmapOutputOptions& options) {
  return encode_lightmap(results_of(lm), options);
}

std::vector<bake::BakeOutput> encode_lightmap(const LightmapResults& lm, const LightmapOutputOptions& options) {
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

  image::FloatImage irradiance = lm.irradiance_image(options.padding, options.stop ? *options.stop : bake::StopCheck{});
  if (options.finish) options.finish(irradiance);
  common(irradiance, "irradiance", "W/m^2", options.color_space);
  irradiance.metadata["kiln:padding"] = std::to_string(options.padding);

  image::FloatImage validity = lm.validity_image();
  common(validity, "validity", "1 valid, 0 invalid (before dilation)", "data");

  image::FloatImage error = lm.error_image(options.error_floor, options.metric);
  common(error, "relative error",
         options.metric == ErrorMetric::texel
             ? "standard error of the mean luminance / max(mean luminance, floor)"
             : "standard error of the mean luminance / max(lightmap brightness, floor)",
         "data");
  error.metadata["kiln:error_floor"] = bake::format_number(options.error_floor);
  error.metadata["kiln:error_metric"] = to_string(options.metric);
  if (options.metric == ErrorMetric::lightmap) error.metadata["kiln:brightness"] = bake::format_number(lm.brightness());

  std::vector<bake::BakeOutput> out;
  out.push_back({lm.name() + "_irradiance.exr", "image/x-exr", "scene_linear", image::encode_exr(irradiance)});
  out.push_back({lm.name() + "_validity.exr", "image/x-exr", "data", image::encode_exr(validity)});
  out.push_back({lm.name() + "_error.exr", "image/x-exr", "data", image::encode_exr(error)});
  return out;
}

}  // namespace kiln::lightmap
