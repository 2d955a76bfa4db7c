// RGB triples in the scene-linear working space: BRDF values, albedos, radiance.
#pragma once

#include <algorithm>
#include <cmath>

namespace kiln {

struct Rgb {
  double r = 0, g = 0, b = 0;

  constexpr Rgb() = default;
  constexpr explicit Rgb(double v) : r(v), g(v), b(v) {}
  constexpr Rgb(double r_, double g_, double b_) : r(r_), g(g_), b(b_) {}

  constexpr Rgb operator+(const Rgb& o) const { return {r + o.r, g + o.g, b + o.b}; }
  constexpr Rgb operator-(const Rgb& o) const { return {r - o.r, g - o.g, b - o.b}; }
  constexpr Rgb operator*(const Rgb& o) const { return {r * o.r, g * o.g, b * o.b}; }
  constexpr Rgb operator*(double s) const { return {r * s, g * s, b * s}; }
  constexpr Rgb operator/(double s) const { return {r / s, g / s, b / s}; }
  constexpr Rgb& operator+=(const Rgb& o) {
    r += o.r;
    g += o.g;
    b += o.b;
    return *this;
  }
  constexpr Rgb& operator*=(double s) {
    r *= s;
    g *= s;
    b *= s;
    return *this;
  }
  constexpr bool operator==(const Rgb&) const = default;

  constexpr double operator[](int i) const { return i == 0 ? r : (i == 1 ? g : b); }
  constexpr double max() const { return std::max(r, std::max(g, b)); }
  constexpr double min() const { return std::min(r, std::min(g, b)); }
  constexpr double average() const { return (r + g + b) / 3.0; }
  constexpr bool is_black() const { return r == 0 && g == 0 && b == 0; }
  bool is_finite() const { return std::isfinite(r) && std::isfinite(g) && std::isfinite(b); }
};

constexpr Rgb operator*(double s, const Rgb& c) { return c * s; }
inline Rgb lerp(double t, const Rgb& a, const Rgb& b) { return a * (1.0 - t) + b * t; }

// Rec. 709 / sRGB luminance (the Y of CIE XYZ for linear Rec. 709 primaries). kiln uses it to steer sampling (light
// choice, importance maps), to find suns and to expose previews: places where any positive weights stay correct, so
// a working space other than Rec. 709 changes only efficiency, never an answer.
inline double luminance(const Rgb& c) { return 0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b; }

}  // namespace kiln
