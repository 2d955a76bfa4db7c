#include "bakers/material/material_preview.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "bakers/bake/cancelled.h"
#include "bakers/image/display_png.h"
#include "bakers/image/png.h"
#include "bakers/math/owen_sobol.h"

namespace kiln::material {
namespace {

enum Panel { studio = 0, sun = 1, furnace = 2 };

// 0 below `lo`, 1 above `hi`, a cubic in between: soft edges keep the environment smooth for importance sampling.
double smoothstep(double lo, double hi, double x) {
  const double t = std::clamp((x - lo) / (hi - lo), 0.0, 1.0);
  return t * t * (3 - 2 * t);
}

// A soft box: `peak` within `inner` radians of `axis`, falling smoothly to 0 at `outer`.
double soft_box(const Vec3& w, const Vec3& axis, double inner, double outer, double peak) {
  return peak * smoothstep(std::cos(outer), std::cos(inner), dot(w, axis));
}

struct Pixel {
  bool on_sphere = false;
  Frame frame;  // around the sphere's normal
  Vec3 wo;      // towards the camera, local
};

// Pixel (x, y) of a panel S pixels wide: the sphere's normal there, seen by a camera looking along −Z.
Pixel sphere_pixel(int x, int y, int size) {
  const double u = (x + 0.5) / size * 2 - 1, v = 1 - (y + 0.5) / size * 2;
  const double r2 = u * u + v * v;
  Pixel p;
  if (!(r2 < 1)) return p;
  const Vec3 n{u, v, std::sqrt(1 - r2)};
  p.on_sphere = true;
  p.frame = Frame::from_normal(n);
  p.wo = p.frame.to_local({0, 0, 1});
  return p;
}

// The panel's environment radiance towards world direction `w`.
double environment(Panel panel, const Vec3& w) {
  switch (panel) {
    case studio:
      return studio_radiance(w);
    case sun:
      return kSkyRadiance;
    case furnace:
      return 1.0;
  }
  return 0.0;
}

// L_o at one pixel: the environment by the model's importance sampling, and the sun's delta term.
Rgb shade(const brdf::Bxdf& bxdf, Panel panel, const Pixel& p, const PreviewOptions& o, uint32_t pixel_seed) {
  Rgb sum(0, 0, 0);
  for (int i = 0; i < o.samples_per_pixel; ++i) {
    const uint32_t index = static_cast<uint32_t>(i);
    const Point2 u = owen_sobol_2d(index, pixel_seed);
    const double uc = owen_sobol_1d(index, pixel_seed ^ 0x68e31da4u);
    // A failed sample (below the horizon) carries no energy: it counts with weight 0.
    if (const auto s = bxdf.sample(p.wo, u, uc)) sum += s->weight * environment(panel, p.frame.from_local(s->wi));
  }
  Rgb L = sum / static_cast<double>(o.samples_per_pixel);
  if (panel == sun) {
    const Vec3 wi = p.frame.to_local(sun_direction());
    // The sun below the pixel's horizon: the sphere shadows itself there.
    if (wi.z > 0) L += bxdf.eval(p.wo, wi) * (kSunIrradiance * wi.z);
  }
  return L;
}

void render_row(const brdf::Bxdf& material, const brdf::Bxdf& white, const PreviewOptions& o, int y,
                PreviewImage& image) {
  const int size = o.sphere_pixels;
  for (int x = 0; x < image.width; ++x) {
    const Panel panel = static_cast<Panel>(x / size);
    const Pixel p = sphere_pixel(x % size, y, size);
    float* out = &image.rgb[(static_cast<size_t>(y) * image.width + x) * 3];
    if (!p.on_sphere) {
      std::fill(out, out + 3, PreviewImage::kBackground);
      continue;
    }
    const uint32_t seed = owen_sobol_detail::hash32(o.seed * 0x9e3779b9u ^ static_cast<uint32_t>(y * image.width + x));
    const Rgb L = shade(panel == furnace ? white : material, panel, p, o, seed);
    out[0] = static_cast<float>(L.r), out[1] = static_cast<float>(L.g), out[2] = static_cast<float>(L.b);
  }
}

}  // namespace

double studio_radiance(const Vec3& w) {
  static const Vec3 key = normalize(Vec3{-0.6, 0.6, 0.55}), fill = normalize(Vec3{0.85, 0.15, 0.45});
  const double room = 0.05 + 0.3 * smoothstep(-0.3, 0.8, w.y);
  return room + soft_box(w, key, 0.3, 0.9, 2.5) + soft_box(w, fill, 0.4, 1.1, 0.6);
}

Vec3 sun_direction() { return normalize(Vec3{0.7, 0.6, 0.4}); }

PreviewImage render_preview(const brdf::Bxdf& material, const brdf::Bxdf& white_furnace, const PreviewOptions& o,
                            const std::atomic<bool>* cancel) {
  if (o.sphere_pixels < 8 || o.sphere_pixels > 1024 || o.samples_per_pixel < 1 || o.samples_per_pixel > (1 << 16)) {
    throw std::invalid_argument("preview: sphere_pixels must be in [8, 1024] and samples_per_pixel in [1, 65536]");
  }
  PreviewImage image;
  image.width = 3 * o.sphere_pixels;
  image.height = o.sphere_pixels;
  image.rgb.resize(static_cast<size_t>(image.width) * image.height * 3);
  tbb::parallel_for(0, image.height, [&](int y) {
    if (cancel && cancel->load(std::memory_order_relaxed)) return;
    render_row(material, white_furnace, o, y, image);
  });
  if (cancel && cancel->load()) throw bake::BakeCancelled();
  return image;
}

bake::BakeOutput preview_output(const PreviewImage& image, const std::string& color_space) {
  std::vector<float> linear = image.rgb;
  const int size = image.height;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 2 * size; x < image.width; ++x) {
      float* p = &linear[(static_cast<size_t>(y) * image.width + x) * 3];
      for (int c = 0; c < 3; ++c) p[c] *= static_cast<float>(kFurnaceExposure);
    }
  }
  image::Png8Image png = image::display_png8(std::move(linear), image.width, image.height, 1.0, color_space);
  png.metadata["Description"] =
      "kiln material preview: the material under a studio environment, under a sun, and its white-furnace form in a "
      "uniform environment of radiance 1 (exposed by 0.5: energy kept is linear 0.5, brighter is energy gained)";
  return {"preview.png", "image/png", "srgb_display", image::encode_png(png)};
}

}  // namespace kiln::material
