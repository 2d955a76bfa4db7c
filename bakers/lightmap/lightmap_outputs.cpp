#include "bakers/lightmap/lightmap_outputs.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <stdexcept>

#include "bakers/bake/number_format.h"
#include "bakers/image/color.h"
#include "bakers/image/display_png.h"
#include "bakers/image/exr.h"
#include "bakers/image/png.h"
#include "bakers/lightmap/dilate.h"
#include "bakers/lightmap/texel_guides.h"
#include "bakers/math/constants.h"
#include "bakers/math/sampling.h"

namespace kiln::lightmap {
namespace {

using bake::format_number;

// The base colour times the texture at a texel sample's texture UV (nearest texel, wrapped), or times the texture's
// average when the sample's mesh has no texture UVs.
Rgb tint_at(const scene::Scene& s, const ShadingMaterial& m, const TexelSample& t) {
  const scene::Mesh& mesh = s.meshes[t.triangle.mesh];
  if (m.texture < 0 || mesh.uv.empty()) return m.base_color * m.texture_average;
  const scene::Texture& tex = s.textures[m.texture];
  const uint32_t* idx = &mesh.indices[3 * t.triangle.triangle];
  const double b1 = t.barycentric.x, b2 = t.barycentric.y, b0 = 1 - b1 - b2;
  const Point2 uv{b0 * mesh.uv[idx[0]].x + b1 * mesh.uv[idx[1]].x + b2 * mesh.uv[idx[2]].x,
                  b0 * mesh.uv[idx[0]].y + b1 * mesh.uv[idx[1]].y + b2 * mesh.uv[idx[2]].y};
  const int x = std::clamp(static_cast<int>((uv.x - std::floor(uv.x)) * tex.width), 0, tex.width - 1);
  const int y = std::clamp(static_cast<int>((uv.y - std::floor(uv.y)) * tex.height), 0, tex.height - 1);
  return m.base_color * tex.texels[static_cast<size_t>(y) * tex.width + x];
}

// Diffuse reflectance at a texel sample (for NAME_radiance.exr, ρE/π): the material's directional-hemispherical
// albedo at normal incidence with its base colour and texture — what a Lambertian approximation of it reflects.
Rgb reflectance(const scene::Scene& s, const std::vector<ShadingMaterial>& materials, const TexelSample& t) {
  const scene::Mesh& mesh = s.meshes[t.triangle.mesh];
  const uint32_t index = mesh.material.empty() ? 0 : mesh.material[t.triangle.triangle];
  const ShadingMaterial& m = materials[index];
  const Rgb tint = tint_at(s, m, t);
  if (m.lambertian) return m.lambertian->A + m.lambertian->B * tint;  // the same albedo in every direction
  // The albedo of the material seen from the normal (μ = 1), with the tint on its diffuse part.
  const Vec3 n{0, 0, 1};
  Rgb albedo;
  constexpr int kDirections = 64;  // a fixed stratified cosine quadrature: ample for a preview-grade ρ
  for (int i = 0; i < kDirections; ++i) {
    for (int j = 0; j < 4; ++j) {
      const Vec3 wi = sample_cosine_hemisphere({(i + 0.5) / kDirections, (j + 0.5) / 4});
      albedo += m.bsdf->eval(n, wi, tint) * kPi;  // f cos / (cos/π)
    }
  }
  return albedo / (4.0 * kDirections);
}

image::FloatImage texel_image(const LightmapResults& r, int channels, const std::vector<std::string>& names,
                              const std::function<void(size_t, float*)>& fill) {
  image::FloatImage out;
  out.width = r.width();
  out.height = r.height();
  out.channels = channels;
  out.channel_names = names;
  out.pixels.assign(static_cast<size_t>(out.width) * out.height * channels, 0.0f);
  for (size_t t = 0; t < r.texel_count(); ++t) {
    if (r.valid(t)) fill(t, &out.pixels[t * channels]);
  }
  return out;
}

// The estimated relative error of a texel's SH from the spread of its n estimates as if they were independent (an
// overestimate where the stratified first vertices make them anti-correlated; luminance throughout): the
// standard error of L00 relative to L00, and that of the L1 vector relative to √3·L00 (the largest |L1| a
// non-negative radiance has: all of it arriving from one direction), whichever is larger. +∞ below two estimates;
// 0 for a black texel (all estimates 0).
double sh_relative_error(const std::array<Rgb, 4>& sum, const std::array<double, 4>& sum_y2, uint32_t n) {
  if (n < 2) return std::numeric_limits<double>::infinity();
  double se[4];
  for (int c = 0; c < 4; ++c) se[c] = standard_error_of_mean(luminance(sum[c]), sum_y2[c], n);
  const double l00 = luminance(sum[0]) / n;
  if (!(l00 > 0)) return 0;  // no radiance arrives: every estimate was 0
  return std::max(se[0] / l00, std::hypot(se[1], se[2], se[3]) / (std::sqrt(3.0) * l00));
}

// The irradiance through the display transform, exposed by image::auto_exposure's rule over the valid texels
// (the median to mid-grey, else the mean, else 1); the Description and kiln:exposure_rule say which applied.
std::string preview_png(const image::FloatImage& irradiance, const std::vector<uint8_t>& validity,
                        const std::string& color_space, const std::string& name) {
  // The key: the valid texels' luminances (invalid texels are not part of any surface).
  std::vector<double> luma;
  for (size_t t = 0; t < validity.size(); ++t) {
    if (!validity[t]) continue;
    const float* p = &irradiance.pixels[t * 3];
    luma.push_back(luminance(Rgb(p[0], p[1], p[2])));
  }
  const image::AutoExposure auto_exposure = image::auto_exposure(std::move(luma));
  const double exposure = auto_exposure.multiplier;
  const std::string rule = image::describe_exposure(auto_exposure, "valid texel", "every valid texel is black");
  image::Png8Image png =
      image::display_png8(irradiance.pixels, irradiance.width, irradiance.height, exposure, color_space);
  png.metadata["Description"] = "kiln lightmap " + name + ": irradiance, exposure " + rule;
  png.metadata["kiln:exposure"] = format_number(exposure);
  png.metadata["kiln:exposure_rule"] = rule;
  return image::encode_png(png);
}

}  // namespace

namespace {

void check_tile_inside(int x0, int y0, int w, int h, const LightmapResults& out) {
  if (x0 < 0 || y0 < 0 || x0 + w > out.width() || y0 + h > out.height()) {
    throw std::invalid_argument("lightmap '" + out.name() + "': a " + std::to_string(w) + "x" + std::to_string(h) +
                                " tile at " + std::to_string(x0) + "," + std::to_string(y0) + " is not inside the " +
                                std::to_string(out.width()) + "x" + std::to_string(out.height()) + " page");
  }
}

// The guides' channels of texel t of a tile into texel p of its page.
void copy_guides(const TexelGuides& guides, size_t t, size_t p, LightmapResults& out) {
  out.guides.valid[p] = 1;
  out.guides.position[p] = guides.position[t];
  out.guides.normal[p] = guides.normal[t];
  out.guides.texel_size[p] = guides.texel_size[t];
  out.guides.chart[p] = guides.chart[t];
}

}  // namespace

void collect_results(const LightmapState& m, int x0, int y0, const ResultsContext& context, LightmapResults& out) {
  const LightmapImage& img = m.image;
  const int w = img.width(), h = img.height();
  check_tile_inside(x0, y0, w, h, out);
  const ResultChannels& c = out.channels();
  std::optional<TexelGuides> guides;
  if (c.guides) guides = texel_guides(m, *context.scene, *context.charts);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t t = static_cast<size_t>(y) * w + x;
      const size_t p = static_cast<size_t>(y0 + y) * out.width() + (x0 + x);
      out.set(p, img.valid(t), img.mean(t), img.standard_error(t), img.count(t));
      if (!img.valid(t)) continue;
      const uint32_t n = img.count(t);
      if (c.ao) out.ao[p] = n ? static_cast<float>(m.ao_sum[t].r / n) : 0.0f;
      if (c.directional) {
        for (int k = 0; k < 4; ++k) {
          for (int ch = 0; ch < 3; ++ch) out.sh[p][3 * k + ch] = n ? static_cast<float>(m.sh_sum[t][k][ch] / n) : 0.0f;
        }
        out.sh_error[p] = sh_relative_error(m.sh_sum[t], m.sh_y2[t], n);
      }
      if (c.radiance) {
        Rgb rho;
        double weight = 0;
        for (const TexelSample& ts : m.texels.at(t)) {
          rho += reflectance(*context.scene, *context.materials, ts) * ts.weight;
          weight += ts.weight;
        }
        const Rgb L = img.mean(t) * (weight > 0 ? rho / weight : Rgb{}) / kPi;
        out.radiance[p] = {static_cast<float>(L.r), static_cast<float>(L.g), static_cast<float>(L.b)};
      }
      if (guides) copy_guides(*guides, t, p, out);
    }
  }
}

void collect_unsampled(const LightmapTexels& texels, int x0, int y0, const ResultsContext& context,
                       LightmapResults& out) {
  const int w = texels.width, h = texels.height;
  check_tile_inside(x0, y0, w, h, out);
  const std::vector<uint8_t> validity = texels.validity();
  std::optional<TexelGuides> guides;
  if (out.channels().guides) guides = texel_guides(texels, validity, *context.charts);
  // No estimate: the mean is black, the standard error unknown (LightmapImage::standard_error's +∞), the count 0;
  // the AO, SH and radiance a count of 0 gives are the page's zeros already, the SH error +∞ (sh_relative_error).
  constexpr double kUnknown = std::numeric_limits<double>::infinity();
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t t = static_cast<size_t>(y) * w + x;
      const size_t p = static_cast<size_t>(y0 + y) * out.width() + (x0 + x);
      const bool valid = validity[t] != 0;
      out.set(p, valid, Rgb{}, valid ? kUnknown : 0.0, 0);
      if (!valid) continue;
      if (out.channels().directional) out.sh_error[p] = kUnknown;
      if (guides) copy_guides(*guides, t, p, out);
    }
  }
}

LightmapResults collect_results(const LightmapState& m, const ResultChannels& channels, const ResultsContext& context) {
  LightmapResults r(m.name, m.image.width(), m.image.height(), channels);
  collect_results(m, 0, 0, context, r);
  return r;
}

bake::BakeOutput denoised_output(const LightmapResults& r, const DenoiseOptions& options, int padding,
                                 const std::string& color_space, const bake::StopCheck& stop,
                                 const ImageFinish& finish) {
  std::vector<Rgb> mean(r.texel_count());
  std::vector<double> variance(r.texel_count(), 0.0);
  for (size_t t = 0; t < r.texel_count(); ++t) {
    if (!r.valid(t)) continue;
    mean[t] = r.mean(t);
    const double standard_error = r.standard_error(t);  // ∞ while a replica has no estimate
    variance[t] = standard_error * standard_error;
  }
  const DenoiseResult d = denoise(mean, variance, r.guides, options);
  constexpr double kMax = std::numeric_limits<float>::max();  // beyond it, an infinity in the file
  image::FloatImage out = texel_image(r, 3, {"R", "G", "B"}, [&](size_t t, float* px) {
    for (int c = 0; c < 3; ++c) px[c] = static_cast<float>(std::clamp(d.colour[t][c], -kMax, kMax));
  });
  dilate(out, r.validity(), padding, stop);
  if (finish) finish(out);
  out.metadata["kiln:content"] = "irradiance, denoised by an " + describe(options);
  out.metadata["kiln:units"] = "W/m^2";
  out.metadata["kiln:colorspace"] = color_space;
  out.metadata["kiln:lightmap"] = r.name();
  out.metadata["kiln:resolution"] = std::to_string(r.width()) + "x" + std::to_string(r.height());
  out.metadata["kiln:uv_convention"] = kLightmapUvConvention;
  out.metadata["kiln:padding"] = std::to_string(padding);
  return {r.name() + "_irradiance_denoised.exr", "image/x-exr", "scene_linear", image::encode_exr(out)};
}

bake::BakeOutput radiance_output(const LightmapResults& r, const std::string& color_space, int padding,
                                 const bake::StopCheck& stop, const ImageFinish& finish) {
  image::FloatImage rad = texel_image(r, 3, {"R", "G", "B"}, [&](size_t t, float* px) {
    for (int c = 0; c < 3; ++c) px[c] = r.radiance[t][c];
  });
  dilate(rad, r.validity(), padding, stop);
  if (finish) finish(rad);
  rad.metadata["kiln:content"] = "baked diffuse radiance rho*E/pi, W/(m^2 sr)";
  rad.metadata["kiln:lightmap"] = r.name();
  rad.metadata["kiln:padding"] = std::to_string(padding);
  return {r.name() + "_radiance.exr", "image/x-exr", color_space, image::encode_exr(rad)};
}

bake::BakeOutput ao_output(const LightmapResults& r, double ao_distance, int padding, const bake::StopCheck& stop,
                           const ImageFinish& finish) {
  image::FloatImage ao = texel_image(r, 1, {"Y"}, [&](size_t t, float* px) { px[0] = r.ao[t]; });
  dilate(ao, r.validity(), padding, stop);
  if (finish) finish(ao);
  ao.metadata["kiln:content"] =
      "ambient occlusion: cosine-weighted fraction of rays unoccluded within " + format_number(ao_distance);
  ao.metadata["kiln:lightmap"] = r.name();
  ao.metadata["kiln:padding"] = std::to_string(padding);
  return {r.name() + "_ao.exr", "image/x-exr", "data", image::encode_exr(ao)};
}

ShError sh_error(const LightmapResults& r) {
  ShError error;
  double sum_sq = 0;
  size_t estimated = 0;
  for (size_t t = 0; t < r.texel_count(); ++t) {
    if (!r.valid(t)) continue;
    const double e = r.sh_error[t];
    if (!std::isfinite(e)) continue;
    sum_sq += e * e;
    error.max = std::max(error.max, e);
    ++estimated;
  }
  error.rms = estimated ? std::sqrt(sum_sq / static_cast<double>(estimated)) : -1;
  return error;
}

bake::BakeOutput sh_output(const LightmapResults& r, const ShError& error, const std::string& color_space) {
  image::FloatImage sh = texel_image(
      r, 12,
      {"L00.R", "L00.G", "L00.B", "L1m1.R", "L1m1.G", "L1m1.B", "L10.R", "L10.G", "L10.B", "L11.R", "L11.G", "L11.B"},
      [&](size_t t, float* px) { std::copy(r.sh[t].begin(), r.sh[t].end(), px); });
  sh.metadata["kiln:content"] =
      "order-1 SH of incoming radiance L(w), world axes: L00 (Y00 = 0.282095), L1m1 (0.488603 y), L10 "
      "(0.488603 z), L11 (0.488603 x)";
  sh.metadata["kiln:lightmap"] = r.name();
  sh.metadata["kiln:error_rms"] = format_number(error.rms);
  sh.metadata["kiln:error"] =
      "estimated relative standard error per texel: of L00, and of the L1 vector relative to sqrt(3) L00, the "
      "larger; RMS over valid texels in kiln:error_rms, also in report.json";
  return {r.name() + "_sh.exr", "image/x-exr", color_space, image::encode_exr(sh)};
}

bake::BakeOutput preview_output(const LightmapResults& r, int padding, const std::string& color_space,
                                const bake::StopCheck& stop, const ImageFinish& finish) {
  image::FloatImage irradiance = r.irradiance_image(padding, stop);
  if (finish) finish(irradiance);
  return {r.name() + "_preview.png", "image/png", "srgb_display",
          preview_png(irradiance, r.validity(), color_space, r.name())};
}

}  // namespace kiln::lightmap
