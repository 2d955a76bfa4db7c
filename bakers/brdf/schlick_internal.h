// Small pieces the Schlick model's files share (schlick_*.cpp only; not part of the brdf interface).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>

#include "bakers/math/quadrature.h"
#include "bakers/math/vec3.h"

namespace kiln::brdf::detail {

// Gauss–Legendre rules on [0, 1] with 1 to 32 nodes, built once (the constructor of a model must stay cheap).
inline const QuadratureRule& unit_rule(int n) {
  static const std::array<QuadratureRule, 33> rules = [] {
    std::array<QuadratureRule, 33> r;
    for (int i = 1; i <= 32; ++i) r[i] = gauss_legendre(i, 0.0, 1.0);
    return r;
  }();
  return rules[std::clamp(n, 1, 32)];
}

inline double pow5(double x) {
  const double x2 = x * x;
  return x2 * x2 * x;
}

// sin²φ of a direction; the normal itself has no azimuth and reads 0 (every azimuth agrees there).
inline double sin2_phi(const Vec3& w) {
  const double rho2 = w.x * w.x + w.y * w.y;
  return rho2 > 0 ? w.y * w.y / rho2 : 0.0;
}

// Unit half vector of two directions of the upper hemisphere. Scaled first, so that directions nearly opposite
// along the horizon (|wo + wi| as small as 1e-200) do not underflow to a zero vector.
inline Vec3 half_vector(const Vec3& wo, const Vec3& wi) {
  Vec3 h = wo + wi;  // h.z > 0: both z are > 0
  const double m = std::max({std::fabs(h.x), std::fabs(h.y), h.z});
  h = h / m;
  return h / length(h);
}

}  // namespace kiln::brdf::detail
