// The environment preview: the documented size and metadata, split-sum shading against the formula, the background
// against the environment, silhouettes where the geometry puts them, level interpolation and the ends of the chain.
// Expected 8-bit values are computed here from the sRGB transfer function itself (IEC 61966-2-1), not through
// OpenColorIO: the tolerance of one code covers the rounding of the two computations (float vs double, OpenColorIO's
// own evaluation of the curve) at a code boundary.
#include "bakers/envmap/preview.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "bakers/image/png.h"
#include "bakers/math/constants.h"

namespace kiln::envmap {
namespace {

int srgb_code(double linear) {
  const double v = std::clamp(linear, 0.0, 1.0);
  const double e = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
  return static_cast<int>(std::lround(255.0 * e));
}

DfgTable constant_dfg(double scale, double bias, int size = 4) {
  DfgTable t;
  t.size_mu = t.size_roughness = size;
  DfgEntry e;
  e.scale = scale;
  e.bias = bias;
  e.energy = scale + bias;
  t.entries.assign(static_cast<size_t>(size) * size, e);
  return t;
}

double rec709_luminance(const Rgb& c) { return 0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b; }

// How pixel (x, y)'s square lies against the disc of sphere i: 1 wholly inside, −1 wholly outside, 0 straddling.
int coverage(int i, int x, int y) {
  const double cx = preview_sphere_center_x(i), cy = kPreviewSphereCenterY, r = kPreviewSphereRadius;
  // Nearest and farthest points of the square [x, x+1] × [y, y+1] from the centre.
  const double nx = std::clamp(cx, double(x), x + 1.0) - cx, ny = std::clamp(cy, double(y), y + 1.0) - cy;
  const double fx = std::max(std::abs(x - cx), std::abs(x + 1 - cx)),
               fy = std::max(std::abs(y - cy), std::abs(y + 1 - cy));
  if (fx * fx + fy * fy <= r * r) return 1;
  if (nx * nx + ny * ny > r * r) return -1;
  return 0;
}

// Which sphere's disc pixel (x, y) is in or touches, −1 for none, and whether wholly (coverage 1).
int sphere_at(int x, int y, int& cover) {
  for (int i = 0; i < kPreviewSpheres; ++i) {
    cover = coverage(i, x, y);
    if (cover >= 0) return i;
  }
  cover = -1;
  return -1;
}

void expect_code(const image::Png8Image& png, int x, int y, const Rgb& linear, const char* what) {
  for (int c = 0; c < 3; ++c) {
    // One 8-bit code: see the file comment.
    ASSERT_NEAR(png.at(x, y, c), srgb_code(linear[c]), 1)
        << what << " at pixel (" << x << ", " << y << ") channel " << c;
  }
}

TEST(Preview, ConstantEnvironmentGivesTheSplitSumValueEverywhere) {
  const Rgb c{0.2, 0.5, 1.0};
  const std::vector<Cubemap> chain = {Cubemap(8, c), Cubemap(4, c), Cubemap(2, c)};
  const double scale = 0.6, bias = 0.1;
  const std::string bytes =
      render_preview(chain, {0.0, 0.5, 1.0}, Cubemap(4, c * kPi), constant_dfg(scale, bias), "lin_rec709");
  const image::Png8Image png = image::decode_png(bytes);
  ASSERT_EQ(png.width, kPreviewWidth);
  ASSERT_EQ(png.height, kPreviewHeight);
  ASSERT_EQ(png.channels, 3);
  // Automatic exposure: the background is c everywhere, so its median luminance is Y(c) and k = 0.18 / Y(c).
  const double k = kPreviewMidGrey / rec709_luminance(c);
  ASSERT_TRUE(png.metadata.count("kiln:exposure"));
  // Printed with round-trip precision; 1e-9 relative is the rounding of Y(c) summed in another order.
  EXPECT_NEAR(std::stod(png.metadata.at("kiln:exposure")), k, 1e-9 * k);
  EXPECT_NEAR(std::stod(png.metadata.at("kiln:exposure_ev")), std::log2(k), 1e-9);
  EXPECT_EQ(png.metadata.at("kiln:display_view"), "sRGB/Standard");
  EXPECT_EQ(png.metadata.at("kiln:color_space"), "lin_rec709");
  EXPECT_NE(png.metadata.at("Description").find("f0 = 1"), std::string::npos);

  // Metal spheres (f0 = 1): c · (f0 · scale + bias); the diffuse sphere (albedo 1): albedo · πc / π = c; the
  // background: c. All exposed by k.
  const Rgb metal = c * ((1.0 * scale + bias) * k), diffuse = c * k, background = c * k;
  int inside = 0, outside = 0, edge = 0;
  for (int y = 0; y < kPreviewHeight; ++y) {
    for (int x = 0; x < kPreviewWidth; ++x) {
      int cover;
      const int i = sphere_at(x, y, cover);
      const Rgb sphere = i == kPreviewSpheres - 1 ? diffuse : metal;
      if (cover == 1) {
        expect_code(png, x, y, sphere, "inside a sphere");
        ++inside;
      } else if (cover == -1) {
        expect_code(png, x, y, background, "background");
        ++outside;
      } else {
        // A straddling pixel mixes the two: between them (one code of slack each way).
        for (int ch = 0; ch < 3; ++ch) {
          const int a = srgb_code(sphere[ch]), b = srgb_code(background[ch]);
          ASSERT_GE(png.at(x, y, ch), std::min(a, b) - 1) << x << "," << y;
          ASSERT_LE(png.at(x, y, ch), std::max(a, b) + 1) << x << "," << y;
        }
        ++edge;
      }
    }
  }
  // Six discs of radius 48 cover 6π48² ≈ 43 429 pixels; the straddling ring is about 6 · 2π · 48 · √2 wide-ish.
  EXPECT_GT(inside, 40000);
  EXPECT_GT(outside, kPreviewWidth * kPreviewHeight - 46000);
  EXPECT_GT(edge, 1000);
}

TEST(Preview, SilhouetteIsWhereTheGeometrySays) {
  // Black spheres (f0 = 0 with a zero DFG bias; albedo 0) on a white background (exposure 1): a pixel's linear value is
  // the fraction of its 16 documented sub-pixel samples, at (x + (i + ½)/4, y + (j + ½)/4), that miss every disc —
  // counted here from the documented centres and radius.
  const std::vector<Cubemap> chain = {Cubemap(4, Rgb(1.0))};
  PreviewOptions opt;
  opt.f0 = 0.0;
  opt.diffuse_albedo = 0.0;
  opt.exposure = 1.0;
  const image::Png8Image png =
      image::decode_png(render_preview(chain, {0.0}, Cubemap(2, Rgb(kPi)), constant_dfg(0.5, 0.0), "lin_rec709", opt));
  int partial = 0;
  for (int y = 0; y < kPreviewHeight; ++y) {
    for (int x = 0; x < kPreviewWidth; ++x) {
      int misses = 0;
      for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 4; ++i) {
          const double sx = x + (i + 0.5) / 4, sy = y + (j + 0.5) / 4;
          bool hit = false;
          for (int s = 0; s < kPreviewSpheres; ++s) {
            const double dx = sx - preview_sphere_center_x(s), dy = sy - kPreviewSphereCenterY;
            hit |= dx * dx + dy * dy <= kPreviewSphereRadius * kPreviewSphereRadius;
          }
          misses += hit ? 0 : 1;
        }
      if (misses > 0 && misses < 16) ++partial;
      // One code (file comment): the value is exactly misses/16 in linear light.
      ASSERT_NEAR(png.at(x, y, 0), srgb_code(misses / 16.0), 1) << "pixel (" << x << ", " << y << ")";
    }
  }
  // The antialiased ring: about 6 × 2π × 48 ≈ 1800 pixels straddle a circle.
  EXPECT_GT(partial, 1000);
}

TEST(Preview, BackgroundIsTheEnvironmentAsDocumented) {
  // L(d) = 0.1 + 0.4 (d.x + 1), linear in d (bilinear on a 64² cube reproduces it to ~1e-3, below a code), brighter
  // towards +X: the right half of the panorama (u > ½ looks towards +X) is brighter than the left.
  const auto radiance = [](const Vec3& d) { return Rgb(0.1 + 0.4 * (d.x + 1.0), 0.3, 0.1 + 0.2 * (d.y + 1.0)); };
  const std::vector<Cubemap> chain = {cubemap_from(64, radiance)};
  PreviewOptions opt;
  opt.exposure = 1.0;
  const image::Png8Image png =
      image::decode_png(render_preview(chain, {0.0}, Cubemap(2, Rgb(1.0)), constant_dfg(1.0, 0.0), "lin_rec709", opt));
  EXPECT_EQ(png.metadata.at("kiln:exposure_rule"), "given");
  // Rows wholly above and below the spheres (the discs span rows 32 … 127).
  for (int y : {0, 5, 15, 30, 130, 145, 159}) {
    for (int x = 0; x < kPreviewWidth; ++x) {
      // The documented mapping, written out: longitude φ = 2π(u − ½) (0 looks along −Z, +90° along +X), elevation
      // from +45° at the top edge to −45° at the bottom edge.
      const double phi = 2.0 * kPi * ((x + 0.5) / kPreviewWidth - 0.5);
      const double elevation = kPi / 4.0 - (kPi / 2.0) * (y + 0.5) / kPreviewHeight;
      const Vec3 d{std::cos(elevation) * std::sin(phi), std::sin(elevation), -std::cos(elevation) * std::cos(phi)};
      // One code (file comment) plus the curvature of the sub-pixel mean: L is linear in d, d varies by
      // 0.5625° across a pixel, so the mean differs from the centre value by O(1e-5).
      expect_code(png, x, y, radiance(d), "background");
    }
  }
}

TEST(Preview, DfgScaleFollowsTheViewAngle) {
  // scale(μ, ρ) = μ (bilinear reproduces a linear function between texel centres; clamped outside [1/128, 127/128]),
  // bias 0, f0 = 1, a constant environment 1, exposure 1: a metal sphere shows μ = n·v = √(1 − a² − b²).
  DfgTable dfg = constant_dfg(0.0, 0.0, 64);
  for (int j = 0; j < 64; ++j)
    for (int i = 0; i < 64; ++i) dfg.entries[static_cast<size_t>(j) * 64 + i].scale = (i + 0.5) / 64;
  PreviewOptions opt;
  opt.exposure = 1.0;
  const image::Png8Image png =
      image::decode_png(render_preview({Cubemap(4, Rgb(1.0))}, {0.0}, Cubemap(2, Rgb(kPi)), dfg, "lin_rec709", opt));
  for (int i = 0; i < kPreviewSpheres - 1; ++i) {
    for (double a : {0.0, 0.3, 0.6, 0.8}) {
      const int x = static_cast<int>(std::floor(preview_sphere_center_x(i) + a * kPreviewSphereRadius));
      const int y = static_cast<int>(kPreviewSphereCenterY);
      const double pa = (x + 0.5 - preview_sphere_center_x(i)) / kPreviewSphereRadius;
      const double pb = (kPreviewSphereCenterY - (y + 0.5)) / kPreviewSphereRadius;
      const double mu = std::clamp(std::sqrt(1.0 - pa * pa - pb * pb), 0.5 / 64, 63.5 / 64);
      // One code (file comment); μ varies by ≤ 0.02 across a pixel at a = 0.8, and the mean of the 16 samples
      // departs from the centre value by the curvature only, O(1e-4).
      expect_code(png, x, y, Rgb(mu), "metal sphere");
    }
  }
}

TEST(Preview, InterpolatesBetweenLevelsAndClampsBeyondTheChain) {
  // Constant levels 0.1, 0.3, 0.5 at ρ = 0, 0.5, 1; DFG scale 1, bias 0, f0 = 1, exposure 1: the sphere at ρ shows
  // the linear interpolation in ρ: 0.1, 0.2, 0.3, 0.4, 0.5.
  PreviewOptions opt;
  opt.exposure = 1.0;
  const DfgTable dfg = constant_dfg(1.0, 0.0);
  const Cubemap irradiance(2, Rgb(kPi));
  const int y = static_cast<int>(kPreviewSphereCenterY);
  const auto centre = [&](int i) { return static_cast<int>(preview_sphere_center_x(i)); };
  {
    const std::vector<Cubemap> chain = {Cubemap(8, Rgb(0.1)), Cubemap(4, Rgb(0.3)), Cubemap(2, Rgb(0.5))};
    const image::Png8Image png =
        image::decode_png(render_preview(chain, {0.0, 0.5, 1.0}, irradiance, dfg, "lin_rec709", opt));
    const double expected[] = {0.1, 0.2, 0.3, 0.4, 0.5};
    for (int i = 0; i < 5; ++i) expect_code(png, centre(i), y, Rgb(expected[i]), "interpolated level");
  }
  {
    // A chain that stops at ρ = 0.5: ρ = 0.75 and 1 read its last level.
    const std::vector<Cubemap> chain = {Cubemap(8, Rgb(0.1)), Cubemap(4, Rgb(0.3))};
    const image::Png8Image png =
        image::decode_png(render_preview(chain, {0.0, 0.5}, irradiance, dfg, "lin_rec709", opt));
    const double expected[] = {0.1, 0.2, 0.3, 0.3, 0.3};
    for (int i = 0; i < 5; ++i) expect_code(png, centre(i), y, Rgb(expected[i]), "beyond the chain");
  }
  {
    // A chain that starts at ρ = 0.5: ρ below reads its first level.
    const std::vector<Cubemap> chain = {Cubemap(8, Rgb(0.3)), Cubemap(4, Rgb(0.5))};
    const image::Png8Image png =
        image::decode_png(render_preview(chain, {0.5, 1.0}, irradiance, dfg, "lin_rec709", opt));
    const double expected[] = {0.3, 0.3, 0.3, 0.4, 0.5};
    for (int i = 0; i < 5; ++i) expect_code(png, centre(i), y, Rgb(expected[i]), "before the chain");
  }
}

TEST(Preview, BlackAndOverbrightEnvironmentsStayDefined) {
  // A black environment: no median, no mean; exposure 1 and an all-black picture.
  const image::Png8Image black =
      image::decode_png(render_preview({Cubemap(4)}, {0.0}, Cubemap(2), constant_dfg(1.0, 0.0), "lin_rec709"));
  EXPECT_EQ(black.metadata.at("kiln:exposure"), "1");
  for (uint8_t v : black.pixels) ASSERT_EQ(v, 0);
  // Mostly black with a bright sun on the horizon towards −Z (inside the background's ±45° band, but far less than
  // half of it): the median is black and the mean sets the exposure.
  const Cubemap sun = cubemap_from(16, [](const Vec3& d) { return d.z < -0.95 ? Rgb(1e5) : Rgb(0.0); });
  const image::Png8Image sunny =
      image::decode_png(render_preview({sun}, {0.0}, Cubemap(2, Rgb(1.0)), constant_dfg(1.0, 0.0), "lin_rec709"));
  EXPECT_NE(sunny.metadata.at("kiln:exposure_rule").find("mean"), std::string::npos);
  const double k = std::stod(sunny.metadata.at("kiln:exposure"));
  // The sun covers about 3% of the band (a cap of 0.31 sr in 8.9 sr), so the mean is ~3e3 and k ~ 6e-5; 1e-3 only
  // asks that the sun counted at all (a share above 0.2%).
  EXPECT_TRUE(std::isfinite(k) && k > 0.0 && k < 1e-3);
  // The centre column on the horizon (between spheres 2 and 3) looks along −Z, into the sun: 1e5 k > 1, white.
  EXPECT_EQ(sunny.at(kPreviewWidth / 2, kPreviewHeight / 2, 0), 255);
}

TEST(Preview, NonFiniteTexelsDoNotPoisonThePicture) {
  // The bake never produces them (its input is sanitised), but a NaN or infinite texel must neither throw nor spread:
  // the exposure stays finite and the background away from the bad texels keeps its value.
  Cubemap cube(8, Rgb(0.18));
  cube.at(0, 3, 3) = Rgb(std::nan(""), 1.0, 1.0);
  cube.at(4, 4, 4) = Rgb(INFINITY, INFINITY, INFINITY);
  const image::Png8Image png =
      image::decode_png(render_preview({cube}, {0.0}, Cubemap(2, Rgb(kPi)), constant_dfg(1.0, 0.0), "lin_rec709"));
  const double k = std::stod(png.metadata.at("kiln:exposure"));
  EXPECT_TRUE(std::isfinite(k));
  // The bad texels sit at the centres of +X and +Z; the centre column's top pixel looks along −Z at 45° elevation,
  // where every texel is 0.18 (and the median, hence k = 1).
  expect_code(png, kPreviewWidth / 2, 0, Rgb(0.18 * k), "background away from the bad texels");
}

TEST(Preview, RejectsInconsistentInput) {
  const Cubemap c(2, Rgb(1.0));
  const DfgTable dfg = constant_dfg(1.0, 0.0);
  EXPECT_THROW(render_preview(std::vector<Cubemap>{}, {}, c, dfg, "lin_rec709"), std::invalid_argument);
  EXPECT_THROW(render_preview({c, c}, {0.0}, c, dfg, "lin_rec709"), std::invalid_argument);
  EXPECT_THROW(render_preview({c, c}, {0.5, 0.5}, c, dfg, "lin_rec709"), std::invalid_argument);
  EXPECT_THROW(render_preview({c}, {1.5}, c, dfg, "lin_rec709"), std::invalid_argument);
  EXPECT_THROW(render_preview({c}, {0.0}, c, DfgTable{}, "lin_rec709"), std::invalid_argument);
  EXPECT_THROW(render_preview({c}, {0.0}, c, dfg, "no_such_space"), std::invalid_argument);
  PreviewOptions opt;
  opt.exposure = -1.0;
  EXPECT_THROW(render_preview({c}, {0.0}, c, dfg, "lin_rec709", opt), std::invalid_argument);
  opt.exposure.reset();
  opt.view = "NoSuchView";
  EXPECT_THROW(render_preview({c}, {0.0}, c, dfg, "lin_rec709", opt), std::invalid_argument);
}

TEST(Png, RoundTripsPixelsAndText) {
  image::Png8Image img;
  img.width = 5;
  img.height = 3;
  img.channels = 3;
  for (int i = 0; i < 45; ++i) img.pixels.push_back(static_cast<uint8_t>(i * 5));
  img.metadata["kiln:note"] = "hello";
  const std::string bytes = image::encode_png(img);
  EXPECT_EQ(bytes, image::encode_png(img));  // deterministic: no time stamp
  const image::Png8Image back = image::decode_png(bytes);
  EXPECT_EQ(back.pixels, img.pixels);
  EXPECT_EQ(back.metadata.at("kiln:note"), "hello");
  img.metadata["oiio:ColorSpace"] = "x";
  EXPECT_THROW(image::encode_png(img), std::invalid_argument);
  EXPECT_THROW(image::decode_png("not a png"), std::runtime_error);
}

}  // namespace
}  // namespace kiln::envmap
