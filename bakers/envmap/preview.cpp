#include "bakers/envmap/preview.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "bakers/bake/number_format.h"
#include "bakers/image/color.h"
#include "bakers/image/display_png.h"
#include "bakers/math/constants.h"

namespace kiln::envmap {
namespace {

using bake::format_number;

// a + t (b − a): exact when a == b, so that a constant lighting stays that constant through every interpolation.
Rgb lerp_exact(double t, const Rgb& a, const Rgb& b) { return a + (b - a) * t; }
double lerp_exact(double t, double a, double b) { return a + (b - a) * t; }

struct Chain {
  std::vector<const Cubemap*> cubes;
  std::vector<double> roughness;
};

// L_pre(r, ρ): bilinear on each level, linear in ρ between the two levels that bracket it; outside the chain's range
// the nearest end level (a chain that stops short of ρ = 1 cannot blur more than its last level).
Rgb sample_chain(const Chain& chain, const Vec3& r, double rho) {
  const std::vector<double>& rs = chain.roughness;
  if (rho <= rs.front()) return chain.cubes.front()->sample_bilinear(r);
  if (rho >= rs.back()) return chain.cubes.back()->sample_bilinear(r);
  // rs.front() < ρ < rs.back(), so 0 ≤ k < size − 1 and rs[k] ≤ ρ < rs[k + 1].
  const size_t k = static_cast<size_t>(std::upper_bound(rs.begin(), rs.end(), rho) - rs.begin()) - 1;
  const double t = (rho - rs[k]) / (rs[k + 1] - rs[k]);  // rs strictly increasing: the denominator is positive
  const Rgb a = chain.cubes[k]->sample_bilinear(r);
  if (t == 0.0) return a;
  return lerp_exact(t, a, chain.cubes[k + 1]->sample_bilinear(r));
}

// Bilinear between texel centres (μ = (i + ½)/size_mu, ρ = (j + ½)/size_roughness), clamped at the borders.
std::pair<double, double> dfg_scale_bias(const DfgTable& dfg, double mu, double rho) {
  const auto coord = [](double value, int size, int& i0, int& i1, double& t) {
    const double p = std::clamp(value * size - 0.5, 0.0, static_cast<double>(size - 1));
    i0 = static_cast<int>(std::floor(p));
    i1 = std::min(i0 + 1, size - 1);
    t = p - i0;
  };
  int i0, i1, j0, j1;
  double tx, ty;
  coord(mu, dfg.size_mu, i0, i1, tx);
  coord(rho, dfg.size_roughness, j0, j1, ty);
  const auto channel = [&](double DfgEntry::*field) {
    const double top = lerp_exact(tx, dfg.at(i0, j0).*field, dfg.at(i1, j0).*field);
    const double bottom = lerp_exact(tx, dfg.at(i0, j1).*field, dfg.at(i1, j1).*field);
    return lerp_exact(ty, top, bottom);
  };
  return {channel(&DfgEntry::scale), channel(&DfgEntry::bias)};
}

// The background's direction at pixel coordinates (px, py) (continuous): longitude over the width, latitude +45° at
// the top to −45° at the bottom.
Vec3 background_direction(double px, double py) {
  const double u = px / kPreviewWidth;
  const double theta = 0.25 * kPi + 0.5 * kPi * (py / kPreviewHeight);  // polar angle from +Y
  return equirect_uv_to_direction(u, theta * kInvPi);
}

struct Shader {
  const Chain& chain;
  const Cubemap& irradiance;
  const DfgTable& dfg;
  const PreviewOptions& options;

  Rgb background(double px, double py) const {
    return chain.cubes.front()->sample_bilinear(background_direction(px, py));
  }

  // The sphere under (px, py), if any, shaded; false if the point is background.
  bool sphere(double px, double py, Rgb& out) const {
    const double cell = static_cast<double>(kPreviewWidth) / kPreviewSpheres;
    const int i = std::clamp(static_cast<int>(std::floor(px / cell)), 0, kPreviewSpheres - 1);
    const double a = (px - preview_sphere_center_x(i)) / kPreviewSphereRadius;
    const double b = (kPreviewSphereCenterY - py) / kPreviewSphereRadius;
    const double r2 = a * a + b * b;
    if (r2 > 1.0) return false;
    // On the silhouette r2 = 1 and n·v = 0 (grazing): sqrt of a rounding-negative 1 − r2 is guarded by the max.
    const Vec3 n{a, b, std::sqrt(std::max(0.0, 1.0 - r2))};
    const Vec3 v{0.0, 0.0, 1.0};
    const double mu = n.z;  // n·v
    if (i == kPreviewSpheres - 1) {
      out = irradiance.sample_bilinear(n) * (options.diffuse_albedo * kInvPi);
      return true;
    }
    const double rho = kPreviewRoughness[static_cast<size_t>(i)];
    const Vec3 r = n * (2.0 * mu) - v;
    const auto [scale, bias] = dfg_scale_bias(dfg, mu, rho);
    out = sample_chain(chain, r, rho) * (options.f0 * scale + bias);
    return true;
  }
};

void check_inputs(const Chain& chain, const Cubemap& irradiance, const DfgTable& dfg, const PreviewOptions& options) {
  if (chain.cubes.empty()) throw std::invalid_argument("render_preview: the specular chain is empty; pass its levels");
  for (size_t k = 0; k < chain.cubes.size(); ++k) {
    if (chain.cubes[k]->size() < 1) {
      throw std::invalid_argument("render_preview: level " + std::to_string(k) + " of the chain is an empty cube");
    }
    const double rho = chain.roughness[k];
    if (!(rho >= 0.0 && rho <= 1.0)) {
      throw std::invalid_argument("render_preview: roughness of level " + std::to_string(k) +
                                  " must be in [0, 1], got " + format_number(rho));
    }
    if (k > 0 && !(rho > chain.roughness[k - 1])) {
      throw std::invalid_argument("render_preview: the levels' roughness must increase strictly, but level " +
                                  std::to_string(k) + " has " + format_number(rho) + " after " +
                                  format_number(chain.roughness[k - 1]));
    }
  }
  if (irradiance.size() < 1) throw std::invalid_argument("render_preview: the irradiance cube is empty");
  if (dfg.size_mu < 1 || dfg.size_roughness < 1 ||
      dfg.entries.size() != static_cast<size_t>(dfg.size_mu) * dfg.size_roughness) {
    throw std::invalid_argument("render_preview: the DFG table is empty or its entries do not match its " +
                                std::to_string(dfg.size_mu) + "x" + std::to_string(dfg.size_roughness) + " size");
  }
  if (!(options.f0 >= 0.0 && options.f0 <= 1.0)) {
    throw std::invalid_argument("render_preview: f0 must be in [0, 1], got " + format_number(options.f0));
  }
  if (!(options.diffuse_albedo >= 0.0 && options.diffuse_albedo <= 1.0)) {
    throw std::invalid_argument("render_preview: diffuse_albedo must be in [0, 1], got " +
                                format_number(options.diffuse_albedo));
  }
  if (options.exposure && !(std::isfinite(*options.exposure) && *options.exposure > 0.0)) {
    throw std::invalid_argument("render_preview: exposure must be a finite number > 0, got " +
                                format_number(*options.exposure));
  }
}

constexpr int kW = kPreviewWidth, kH = kPreviewHeight, kS = kPreviewSupersampling;

// The centre of subpixel i of a pixel (kS × kS subpixels a pixel).
double subpixel(int pixel, int i) { return pixel + (i + 0.5) / kS; }

// The background everywhere (for the exposure, and for pixels no sphere touches).
std::vector<Rgb> render_background(const Shader& shader) {
  std::vector<Rgb> background(static_cast<size_t>(kW) * kH);
  tbb::parallel_for(tbb::blocked_range<int>(0, kH), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y) {
      for (int x = 0; x < kW; ++x) {
        Rgb sum;
        for (int j = 0; j < kS; ++j)
          for (int i = 0; i < kS; ++i) sum += shader.background(subpixel(x, i), subpixel(y, j));
        background[static_cast<size_t>(y) * kW + x] = sum / (kS * kS);
      }
    }
  });
  return background;
}

struct Exposure {
  double multiplier = 1.0;
  std::string rule;  // how it was chosen, for the PNG's metadata
};

// The given exposure, else the median background luminance → mid-grey (image::auto_exposure's rule).
Exposure choose_exposure(const std::vector<Rgb>& background, const PreviewOptions& options) {
  if (options.exposure) return {*options.exposure, "given"};
  std::vector<double> lum(background.size());
  std::transform(background.begin(), background.end(), lum.begin(), luminance);
  const image::AutoExposure automatic = image::auto_exposure(std::move(lum));
  return {automatic.multiplier, image::describe_exposure(automatic, "background", "a black environment")};
}

// Pixel (x, y): the spheres' subpixels, and the background's where a sphere covers only part of the pixel.
Rgb pixel_value(const Shader& shader, const std::vector<Rgb>& background, int x, int y) {
  Rgb sphere_sum;
  int hits = 0;
  for (int j = 0; j < kS; ++j)
    for (int i = 0; i < kS; ++i) {
      Rgb c;
      if (shader.sphere(subpixel(x, i), subpixel(y, j), c)) {
        sphere_sum += c;
        ++hits;
      }
    }
  if (hits == 0) return background[static_cast<size_t>(y) * kW + x];
  Rgb sum = sphere_sum;
  if (hits < kS * kS) {
    for (int j = 0; j < kS; ++j)
      for (int i = 0; i < kS; ++i) {
        Rgb c;
        if (!shader.sphere(subpixel(x, i), subpixel(y, j), c)) sum += shader.background(subpixel(x, i), subpixel(y, j));
      }
  }
  return sum / (kS * kS);
}

// Spheres over the background, as floats for OpenColorIO.
std::vector<float> render_spheres(const Shader& shader, const std::vector<Rgb>& background) {
  std::vector<float> linear(static_cast<size_t>(kW) * kH * 3);
  tbb::parallel_for(tbb::blocked_range<int>(0, kH), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y) {
      for (int x = 0; x < kW; ++x) {
        const Rgb value = pixel_value(shader, background, x, y);
        float* out = &linear[(static_cast<size_t>(y) * kW + x) * 3];
        for (int c = 0; c < 3; ++c) out[c] = static_cast<float>(value[c]);  // NaN guarded by display_png8
      }
    }
  });
  return linear;
}

// Exposure, display transform and quantisation, with what the picture shows in its metadata.
std::string encode_preview(std::vector<float> linear, const Exposure& exposure, const std::string& color_space,
                           const PreviewOptions& options) {
  image::Png8Image png =
      image::display_png8(std::move(linear), kW, kH, exposure.multiplier, color_space, options.display, options.view);
  png.metadata["Description"] =
      "kiln environment preview, " + std::to_string(kW) + "x" + std::to_string(kH) +
      ". Background: the environment, longitude 360 deg across (centre column looks along -Z), latitude +45 deg "
      "(top) to -45 deg (bottom). Spheres left to right: metal f0 = " +
      format_number(options.f0) +
      " at perceptual roughness 0, 0.25, 0.5, 0.75, 1 (split sum: prefiltered(r) * (f0 * scale + bias)); diffuse "
      "albedo " +
      format_number(options.diffuse_albedo) +
      " lit by the irradiance cube (albedo * E / pi). "
      "Orthographic camera along -Z.";
  png.metadata["kiln:exposure"] = format_number(exposure.multiplier);
  png.metadata["kiln:exposure_ev"] = format_number(std::log2(exposure.multiplier));
  png.metadata["kiln:exposure_rule"] = exposure.rule;
  png.metadata["kiln:color_space"] = color_space;
  return image::encode_png(png);
}

std::string render(const Chain& chain, const Cubemap& irradiance, const DfgTable& dfg, const std::string& color_space,
                   const PreviewOptions& options) {
  check_inputs(chain, irradiance, dfg, options);
  // The colour space, display and view, checked before any work (no pixels: nothing is converted).
  image::ColorConfig::active().convert_to_display(nullptr, 0, 3, color_space, options.display, options.view);
  const Shader shader{chain, irradiance, dfg, options};
  const std::vector<Rgb> background = render_background(shader);
  const Exposure exposure = choose_exposure(background, options);
  return encode_preview(render_spheres(shader, background), exposure, color_space, options);
}

}  // namespace

std::string render_preview(const std::vector<Cubemap>& chain, const std::vector<double>& roughness,
                           const Cubemap& irradiance, const DfgTable& dfg, const std::string& color_space,
                           const PreviewOptions& options) {
  if (chain.size() != roughness.size()) {
    throw std::invalid_argument("render_preview: " + std::to_string(chain.size()) + " chain levels but " +
                                std::to_string(roughness.size()) + " roughness values; give one per level");
  }
  Chain c;
  for (const Cubemap& cube : chain) c.cubes.push_back(&cube);
  c.roughness = roughness;
  return render(c, irradiance, dfg, color_space, options);
}

std::string render_preview(const std::vector<PrefilteredLevel>& chain, const Cubemap& irradiance, const DfgTable& dfg,
                           const std::string& color_space, const PreviewOptions& options) {
  Chain c;
  for (const PrefilteredLevel& level : chain) {
    c.cubes.push_back(&level.cube);
    c.roughness.push_back(level.roughness);
  }
  return render(c, irradiance, dfg, color_space, options);
}

}  // namespace kiln::envmap
