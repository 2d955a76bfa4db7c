#include "bakers/lightmap/denoise.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "bakers/bake/number_format.h"

namespace kiln::lightmap {
namespace {

// The B3 spline, (1, 4, 6, 4, 1)/16: the à-trous scaling function of Dammertz et al. and SVGF.
constexpr double kB3[5] = {1.0 / 16, 1.0 / 4, 3.0 / 8, 1.0 / 4, 1.0 / 16};
constexpr int kMaxLevels = 12;  // steps up to 2048 texels: past any lightmap's chart

// One level's colours, their luminances and variances.
struct Level {
  std::vector<Rgb> colour;
  std::vector<double> luminance;
  std::vector<double> variance;
};

void check(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("denoise: " + what);
}

void check_inputs(const std::vector<Rgb>& colour, const std::vector<double>& variance, const TexelGuides& g,
                  const DenoiseOptions& o) {
  check(g.width >= 0 && g.height >= 0, "the guides' size is negative");
  const size_t n = static_cast<size_t>(g.width) * static_cast<size_t>(g.height);
  const std::string size = std::to_string(g.width) + "x" + std::to_string(g.height);
  check(colour.size() == n && variance.size() == n, "colour and variance need one entry per texel of " + size);
  check(g.valid.size() == n && g.position.size() == n && g.normal.size() == n && g.texel_size.size() == n &&
            g.chart.size() == n,
        "every guide needs one entry per texel of " + size);
  check(o.levels >= 0 && o.levels <= kMaxLevels, "levels must be in [0, 12], got " + std::to_string(o.levels));
  check(o.sigma_luminance > 0 && std::isfinite(o.sigma_luminance), "sigma_luminance must be finite and > 0");
  check(o.sigma_normal >= 0 && std::isfinite(o.sigma_normal), "sigma_normal must be finite and >= 0");
  check(o.sigma_position > 0 && std::isfinite(o.sigma_position), "sigma_position must be finite and > 0");
}

// Sums of 25 such colours stay finite in double.
bool in_float_range(const Rgb& c) {
  constexpr double kMax = std::numeric_limits<float>::max();
  return std::abs(c.r) <= kMax && std::abs(c.g) <= kMax && std::abs(c.b) <= kMax;
}

// The texels the filter reads and writes: valid, with a colour in the float range, a variance and finite guides.
std::vector<uint8_t> usable_texels(const std::vector<Rgb>& colour, const std::vector<double>& variance,
                                   const TexelGuides& g) {
  std::vector<uint8_t> usable(colour.size(), 0);
  for (size_t t = 0; t < colour.size(); ++t) {
    usable[t] = g.valid[t] && in_float_range(colour[t]) && std::isfinite(variance[t]) && variance[t] >= 0 &&
                is_finite(g.position[t]) && is_finite(g.normal[t]) && std::isfinite(g.texel_size[t]) &&
                g.texel_size[t] > 0;
  }
  return usable;
}

// The weight of tap q of texel p without the kernel's h (the header's formula), as one exponential.
double edge_weight(const Level& in, const TexelGuides& g, const DenoiseOptions& o, size_t p, size_t q) {
  double log_w = 0;
  if (o.sigma_normal > 0) {
    const double cos_n = dot(g.normal[p], g.normal[q]);
    if (!(cos_n > 0)) return 0;
    if (cos_n < 1) log_w += o.sigma_normal * std::log(cos_n);  // most taps of a flat chart need no logarithm
  }
  // ε: relative to the texel's own luminance, so the filter does not depend on the unit; the smallest normal double
  // keeps the denominator of an exact black texel positive (taps that are not black then weigh exp(−∞) = 0).
  const double yp = in.luminance[p];
  const double scale =
      o.sigma_luminance * std::sqrt(in.variance[p]) + 1e-9 * std::abs(yp) + std::numeric_limits<double>::min();
  log_w -= std::abs(yp - in.luminance[q]) / scale;
  log_w -= std::abs(dot(g.normal[p], g.position[q] - g.position[p])) / (o.sigma_position * g.texel_size[p]);
  // In single precision (a weight needs no more, and the exponential is most of the filter's time); below e^−80 a
  // tap is nothing beside p's own weight.
  return log_w > -80 ? std::exp(static_cast<float>(log_w)) : 0.0;
}

// Texel (x, y) at one level, taps `step` texels apart.
void filter_texel(const Level& in, Level& out, const TexelGuides& g, const std::vector<uint8_t>& usable,
                  const DenoiseOptions& o, int x, int y, int step) {
  const size_t p = static_cast<size_t>(y) * g.width + x;
  double sum_w = 0, sum_w2v = 0;
  Rgb sum_c;
  for (int j = -2; j <= 2; ++j) {
    const int qy = y + j * step;
    if (qy < 0 || qy >= g.height) continue;
    for (int i = -2; i <= 2; ++i) {
      const int qx = x + i * step;
      if (qx < 0 || qx >= g.width) continue;
      const size_t q = static_cast<size_t>(qy) * g.width + qx;
      if (!usable[q] || g.chart[q] != g.chart[p]) continue;
      const double h = kB3[i + 2] * kB3[j + 2];
      const double w = q == p ? h : h * edge_weight(in, g, o, p, q);
      if (w == 0) continue;
      sum_w += w;
      sum_c += in.colour[q] * w;
      sum_w2v += w * w * in.variance[q];
    }
  }
  // sum_w ≥ h(0) > 0: p itself is a tap of weight h(0).
  out.colour[p] = sum_c / sum_w;
  out.luminance[p] = luminance(out.colour[p]);
  out.variance[p] = sum_w2v / (sum_w * sum_w);
}

void filter_level(const Level& in, Level& out, const TexelGuides& g, const std::vector<uint8_t>& usable,
                  const DenoiseOptions& o, int step) {
  tbb::parallel_for(tbb::blocked_range<int>(0, g.height), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y) {
      for (int x = 0; x < g.width; ++x) {
        if (usable[static_cast<size_t>(y) * g.width + x]) filter_texel(in, out, g, usable, o, x, y, step);
      }
    }
  });
}

// Level 0's input: usable texels as given, the others as the header says they come out (the levels never write
// them).
Level first_level(const std::vector<Rgb>& colour, const std::vector<double>& variance, const TexelGuides& g) {
  const size_t n = colour.size();
  Level l{std::vector<Rgb>(n), std::vector<double>(n, 0.0), std::vector<double>(n, 0.0)};
  for (size_t t = 0; t < n; ++t) {
    if (!g.valid[t]) continue;
    l.colour[t] = colour[t].is_finite() ? colour[t] : Rgb{};
    l.variance[t] = variance[t] >= 0 ? variance[t] : std::numeric_limits<double>::infinity();  // NaN too
    l.luminance[t] = luminance(l.colour[t]);
  }
  return l;
}

}  // namespace

DenoiseResult denoise(const std::vector<Rgb>& colour, const std::vector<double>& variance, const TexelGuides& guides,
                      const DenoiseOptions& options) {
  check_inputs(colour, variance, guides, options);
  const std::vector<uint8_t> usable = usable_texels(colour, variance, guides);
  Level a = first_level(colour, variance, guides);
  Level b = a;  // texels the filter does not write keep their values in both buffers
  for (int level = 0; level < options.levels; ++level) {
    filter_level(a, b, guides, usable, options, 1 << level);
    std::swap(a, b);
  }
  return {std::move(a.colour), std::move(a.variance)};
}

std::string describe(const DenoiseOptions& o) {
  using bake::format_number;
  const std::string steps =
      o.levels > 0 ? "steps 1 to " + std::to_string(1 << (o.levels - 1)) + " texels" : "none: the identity";
  return "edge-avoiding a-trous wavelet filter (Dammertz et al. 2010) weighted by variance (SVGF, Schied et al. "
         "2017): " +
         std::to_string(o.levels) + " levels of a B3-spline kernel (" + steps + "), sigma_luminance " +
         format_number(o.sigma_luminance) + ", sigma_normal " + format_number(o.sigma_normal) + ", sigma_position " +
         format_number(o.sigma_position) + "; never across charts or from invalid texels";
}

}  // namespace kiln::lightmap
