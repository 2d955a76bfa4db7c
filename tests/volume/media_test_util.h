// Shared by the media tests: Monte Carlo means with their standard errors, the heterogeneous test grid, and
// reference transmittances by quadrature.
#pragma once

#include <cmath>
#include <vector>

#include "bakers/math/rgb.h"
#include "bakers/scene/ray_offset.h"
#include "bakers/volume/medium.h"
#include "bakers/volume/vdb_grid.h"

namespace kiln::volume::test {

struct RgbEstimate {
  Rgb mean;
  Rgb standard_error;  // of the mean, from the sample variance
};

// The mean of n draws of f() and its standard error, per channel.
template <class F>
RgbEstimate estimate(int n, F&& f) {
  Rgb sum, sum2;
  for (int i = 0; i < n; ++i) {
    const Rgb x = f();
    sum += x;
    sum2 += x * x;
  }
  const Rgb mean = sum / n, var = sum2 / n - mean * mean;
  auto se = [&](double v) { return std::sqrt(std::max(0.0, v) / (n - 1)); };
  return {mean, {se(var.r), se(var.g), se(var.b)}};
}

// A 32³ grid of voxel edge 1/32 filling [0, 1)³: a smooth lumpy ball of density up to about 3 (zero outside radius
// 0.4 of the centre, so whole leaf nodes are empty), named "density".
inline VdbGrid lumpy_ball_grid() {
  const int n = 32;
  std::vector<float> v(n * n * n);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const double x = (i + 0.5) / n - 0.5, y = (j + 0.5) / n - 0.5, z = (k + 0.5) / n - 0.5;
        const double r = std::sqrt(x * x + y * y + z * z);
        const double lumps = 1.5 + std::sin(17 * x) * std::cos(13 * y) + 0.5 * std::sin(23 * z);
        v[(k * n + j) * n + i] = r < 0.4 ? static_cast<float>(lumps * (1 - r / 0.4)) * 2 : 0.0f;
      }
  return make_vdb_grid("density", n, n, n, v, 1.0 / n);
}

// T = exp(−∫ sigma_t dt) along the ray over [0, t_end), by the midpoint rule with `steps` steps: the integrand is
// continuous and piecewise smooth (trilinear), so its error falls as steps⁻² away from kinks.
inline Rgb quadrature_transmittance(const Medium& medium, const scene::Ray& ray, double t_end, int steps) {
  const double dt = t_end / steps, speed = std::sqrt(dot(ray.direction, ray.direction));
  Rgb tau;
  for (int s = 0; s < steps; ++s) tau += medium.at(ray.origin + ray.direction * ((s + 0.5) * dt)).sigma_t() * dt;
  tau *= speed;
  return {std::exp(-tau.r), std::exp(-tau.g), std::exp(-tau.b)};
}

}  // namespace kiln::volume::test
