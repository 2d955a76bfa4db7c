// kiln-sky: writes a synthetic HDR sky as an equirectangular OpenEXR, for trying the environment bake without a
// captured panorama:
//   kiln-sky [--width W] [--sun-elevation DEG] [--sun-azimuth DEG] [--sun-ratio R] --out sky.exr
// The sky is a clear-day look, not a physical atmosphere: a blue zenith brightening to a whitish horizon
// (1 − sin(elevation))³, a forward-scattering glow around the sun, a uniform grey-brown ground below the horizon,
// and a sun disc R times the zenith's radiance (default 10⁴), the dynamic range a prefilter must cope with.
// Image layout: kiln's equirectangular convention (bakers/envmap/cubemap.h), linear Rec.709 RGB float.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <stdexcept>
#include <string>
#include <vector>

#include "bakers/envmap/cubemap.h"
#include "bakers/image/exr.h"

namespace {

using kiln::Rgb;
using kiln::Vec3;

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

constexpr const char* kUsage = R"(usage: kiln-sky [options] --out FILE.exr

Writes a synthetic clear-day HDR sky, equirectangular (width x width/2), linear Rec.709 RGB float OpenEXR.
  --out FILE             where to write it (required)
  --width W              image width, even, [16, 16384]; default 512 (height W/2)
  --sun-elevation DEG    the sun's angle above the horizon, [0, 90]; default 35
  --sun-azimuth DEG      clockwise from -Z (the image centre) towards +X, [-360, 360]; default 60
  --sun-ratio R          sun radiance over the zenith's, [1, 1e6]; default 10000
  --sun-radius DEG       the disc's angular radius, (0, 10]; default 0.5, widened to a pixel if smaller
)";

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegree = kPi / 180;

double number(const std::string& flag, const std::string& text, double lo, double hi) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !std::isfinite(v) || v < lo || v > hi) {
    throw UsageError(flag + ": expected a number in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got '" +
                     text + "'");
  }
  return v;
}

struct Sky {
  Vec3 sun;             // unit direction towards the sun
  double cos_sun = 1;   // cosine of the disc's angular radius
  double sun_radiance;  // per channel, times kSunColor
  // Zenith and horizon radiance (arbitrary units: the zenith's blue channel is 1).
  Rgb zenith{0.25, 0.45, 1.0};
  Rgb horizon{0.9, 0.95, 1.0};
  Rgb ground{0.18, 0.15, 0.12};
  Rgb sun_color{1.0, 0.95, 0.88};

  Rgb radiance(const Vec3& d) const {
    const double mu_sun = d.x * sun.x + d.y * sun.y + d.z * sun.z;
    if (mu_sun >= cos_sun) return sun_color * sun_radiance;
    if (d.y < 0) return ground;
    // Elevation blend: horizon at y = 0, zenith at y = 1; the cube keeps the bright band near the horizon thin.
    const double t = std::pow(1.0 - d.y, 3.0);
    Rgb sky = zenith * (1 - t) + horizon * t;
    // Forward scattering around the sun: a glow falling off over ~10 degrees.
    const double angle = std::acos(std::clamp(mu_sun, -1.0, 1.0));
    sky = sky + sun_color * (2.0 * std::exp(-angle / (10 * kDegree)));
    return sky;
  }
};

int run(int argc, char** argv) {
  std::string out;
  int width = 512;
  double elevation = 35, azimuth = 60, ratio = 1e4, radius = 0.5;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (flag == "--help" || flag == "-h") {
      std::cout << kUsage;
      return 0;
    }
    if (i + 1 >= argc) throw UsageError(flag + ": missing value (see kiln-sky --help)");
    const std::string value = argv[++i];
    if (flag == "--out") {
      out = value;
    } else if (flag == "--width") {
      width = static_cast<int>(number(flag, value, 16, 16384));
      if (width % 2 != 0) throw UsageError("--width: must be even (the height is width/2), got " + value);
    } else if (flag == "--sun-elevation") {
      elevation = number(flag, value, 0, 90);
    } else if (flag == "--sun-azimuth") {
      azimuth = number(flag, value, -360, 360);
    } else if (flag == "--sun-ratio") {
      ratio = number(flag, value, 1, 1e6);
    } else if (flag == "--sun-radius") {
      radius = number(flag, value, 1e-6, 10);
    } else {
      throw UsageError("unknown option " + flag + " (see kiln-sky --help)");
    }
  }
  if (out.empty()) throw UsageError("--out: missing; where to write the sky (see kiln-sky --help)");
  const int height = width / 2;

  Sky sky;
  const double theta = (90 - elevation) * kDegree, phi = azimuth * kDegree;
  sky.sun = Vec3(std::sin(theta) * std::sin(phi), std::cos(theta), -std::sin(theta) * std::cos(phi));
  // At least a pixel across (π/height per row), so that the disc is never lost between pixel centres.
  sky.cos_sun = std::cos(std::max(radius * kDegree, kPi / height));
  sky.sun_radiance = ratio * sky.zenith.b;

  kiln::image::FloatImage image;
  image.width = width;
  image.height = height;
  image.channels = 3;
  image.channel_names = {"R", "G", "B"};
  image.pixels.resize(static_cast<size_t>(width) * height * 3);
  image.metadata["kiln:content"] = "synthetic clear-day sky by kiln-sky, linear Rec.709 radiance";
  image.metadata["kiln:equirect_convention"] = std::string(kiln::envmap::kEquirectConvention);
  // 4×4 samples per pixel, weighted by their solid angle (∝ sin θ), so the disc's edge and the horizon are
  // antialiased and the sun's power does not depend on where its centre falls.
  constexpr int kSub = 4;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      Rgb sum{0, 0, 0};
      double weight = 0;
      for (int j = 0; j < kSub; ++j) {
        for (int i = 0; i < kSub; ++i) {
          const double u = (x + (i + 0.5) / kSub) / width, v = (y + (j + 0.5) / kSub) / height;
          const double w = std::sin(kPi * v);
          sum = sum + sky.radiance(kiln::envmap::equirect_uv_to_direction(u, v)) * w;
          weight += w;
        }
      }
      const Rgb c = sum * (1.0 / weight);  // weight > 0: every sub-sample has v strictly inside (0, 1)
      for (int ch = 0; ch < 3; ++ch) image.at(x, y, ch) = static_cast<float>(c[ch]);
    }
  }
  const std::string bytes = kiln::image::encode_exr(image);
  std::ofstream file(out, std::ios::binary | std::ios::trunc);
  file.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  file.close();
  if (!file) throw std::runtime_error("cannot write " + out);
  std::cerr << "kiln-sky: wrote " << out << " (" << width << " x " << height << ", sun at elevation " << elevation
            << " deg, " << ratio << " x the zenith)\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const UsageError& e) {
    std::cerr << "kiln-sky: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "kiln-sky: " << e.what() << "\n";
    return 1;
  }
}
