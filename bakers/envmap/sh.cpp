#include "bakers/envmap/sh.h"

#include <cmath>
#include <stdexcept>

#include "bakers/math/constants.h"

namespace kiln::envmap {
namespace {

// Normalisation constants of the orthonormal real basis (see sh.h), computed from their definitions.
const double kC0 = 0.5 / std::sqrt(kPi);             // 1 / (2 √π)
const double kC1 = std::sqrt(3.0 / (4.0 * kPi));     // √(3 / 4π)
const double kC2 = std::sqrt(15.0 / (4.0 * kPi));    // √(15 / 4π)
const double kC20 = std::sqrt(5.0 / (16.0 * kPi));   // √(5 / 16π)
const double kC22 = std::sqrt(15.0 / (16.0 * kPi));  // √(15 / 16π)

}  // namespace

ShBasis sh_basis(const Vec3& d) {
  return {kC0,
          kC1 * d.y,
          kC1 * d.z,
          kC1 * d.x,
          kC2 * d.x * d.y,
          kC2 * d.y * d.z,
          kC20 * (3.0 * d.z * d.z - 1.0),
          kC2 * d.x * d.z,
          kC22 * (d.x * d.x - d.y * d.y)};
}

double sh_cosine_lobe(int l) {
  switch (l) {
    case 0:
      return kPi;
    case 1:
      return 2.0 * kPi / 3.0;
    case 2:
      return kPi / 4.0;
    default:
      throw std::invalid_argument("sh_cosine_lobe: only bands 0..2 are represented");
  }
}

ShCoefficients project_sh(const Cubemap& cube) {
  const int n = cube.size();
  ShCoefficients c{};
  const std::vector<double>& omega = *texel_solid_angles(n);
  for (int f = 0; f < kFaceCount; ++f) {
    for (int y = 0; y < n; ++y) {
      for (int x = 0; x < n; ++x) {
        const double w = omega[static_cast<size_t>(y) * n + x];
        const ShBasis b = sh_basis(texel_direction(f, x, y, n));
        const Rgb lw = cube.at(f, x, y) * w;
        for (int i = 0; i < kShCount; ++i) c[i] += lw * b[i];
      }
    }
  }
  return c;
}

ShCoefficients sh_radiance_to_irradiance(const ShCoefficients& radiance) {
  ShCoefficients e{};
  for (int i = 0; i < kShCount; ++i) e[i] = radiance[i] * sh_cosine_lobe(sh_band(i));
  return e;
}

Rgb evaluate_sh(const ShCoefficients& c, const Vec3& dir) {
  const ShBasis b = sh_basis(dir);
  Rgb sum;
  for (int i = 0; i < kShCount; ++i) sum += c[i] * b[i];
  return sum;
}

}  // namespace kiln::envmap
