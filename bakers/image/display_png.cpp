#include "bakers/image/display_png.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>

#include "bakers/bake/number_format.h"
#include "bakers/image/color.h"

namespace kiln::image {

AutoExposure auto_exposure(std::vector<double> luminances) {
  AutoExposure e;
  // A NaN orders with nothing (std::nth_element needs a strict weak order) and is no light: left out.
  std::erase_if(luminances, [](double l) { return std::isnan(l); });
  if (luminances.empty()) return e;  // nothing to expose for: exposure 1
  const auto mid = luminances.begin() + static_cast<std::ptrdiff_t>(luminances.size() / 2);
  std::nth_element(luminances.begin(), mid, luminances.end());
  const double median = *mid;
  if (median > 0.0 && std::isfinite(median)) {
    e.from = AutoExposure::Key::median;
    e.key = median;
  } else {
    // More than half the pixels are black: the mean still says how bright the rest is (summed as a mean term by term,
    // so that a large picture of large values does not overflow).
    double mean = 0.0;
    for (double l : luminances) mean += l / static_cast<double>(luminances.size());
    if (!(mean > 0.0 && std::isfinite(mean))) return e;  // a black picture: exposure 1
    e.from = AutoExposure::Key::mean;
    e.key = mean;
  }
  e.multiplier = kMidGrey / e.key;
  // A key so small that the multiplier overflows (a picture of denormals): exposure 1, as for black.
  if (!std::isfinite(e.multiplier)) return AutoExposure{};
  return e;
}

Png8Image display_png8(std::vector<float> linear, int width, int height, double exposure,
                       const std::string& color_space, const std::string& display, const std::string& view) {
  const size_t pixels = static_cast<size_t>(std::max(width, 0)) * static_cast<size_t>(std::max(height, 0));
  if (width < 1 || height < 1 || linear.size() != pixels * 3) {
    throw std::invalid_argument("display_png8: " + std::to_string(linear.size()) + " values given for a " +
                                std::to_string(width) + "x" + std::to_string(height) +
                                " RGB picture; give width x height x 3");
  }
  if (!(std::isfinite(exposure) && exposure > 0.0)) {
    throw std::invalid_argument("display_png8: the exposure must be a finite number > 0, got " +
                                std::to_string(exposure));
  }
  for (float& v : linear) {
    const double exposed = v * exposure;
    // NaN (undefined for OpenColorIO) and negative values (not light) become 0; `!(x > 0)` catches both.
    v = exposed > 0.0 ? static_cast<float>(exposed) : 0.0f;
  }
  Png8Image png;
  png.metadata["kiln:display_view"] =
      ColorConfig::active().convert_to_display(linear.data(), pixels, 3, color_space, display, view);
  png.width = width;
  png.height = height;
  png.channels = 3;
  png.pixels.resize(linear.size());
  for (size_t i = 0; i < linear.size(); ++i) {
    const float v = linear[i];
    // A NaN (no display transform should make one) becomes 0; beyond [0, 1] is clamped.
    png.pixels[i] = std::isnan(v) ? 0 : static_cast<uint8_t>(std::lround(255.0 * std::clamp(double(v), 0.0, 1.0)));
  }
  return png;
}

std::string describe_exposure(const AutoExposure& exposure, const std::string& what, const std::string& black) {
  using bake::format_number;
  const std::string to_grey = " -> " + format_number(kMidGrey);
  switch (exposure.from) {
    case AutoExposure::Key::median:
      return "automatic: median " + what + " luminance " + format_number(exposure.key) + to_grey;
    case AutoExposure::Key::mean:
      return "automatic: mean " + what + " luminance " + format_number(exposure.key) + to_grey +
             " (the median is black)";
    case AutoExposure::Key::black:
      break;
  }
  return "automatic: " + black + ", exposure 1";
}

}  // namespace kiln::image
