// Three-component vectors in double precision: directions, points, and the local shading frame.
#pragma once

#include <cmath>

namespace kiln {

struct Vec3 {
  double x = 0, y = 0, z = 0;

  constexpr Vec3() = default;
  constexpr Vec3(double x_, double y_, double z_) : x(x_), y(y_), z(z_) {}

  constexpr Vec3 operator+(const Vec3& b) const { return {x + b.x, y + b.y, z + b.z}; }
  constexpr Vec3 operator-(const Vec3& b) const { return {x - b.x, y - b.y, z - b.z}; }
  constexpr Vec3 operator-() const { return {-x, -y, -z}; }
  constexpr Vec3 operator*(double s) const { return {x * s, y * s, z * s}; }
  constexpr Vec3 operator/(double s) const { return {x / s, y / s, z / s}; }
  constexpr Vec3& operator+=(const Vec3& b) {
    x += b.x;
    y += b.y;
    z += b.z;
    return *this;
  }
  constexpr bool operator==(const Vec3&) const = default;
};

constexpr Vec3 operator*(double s, const Vec3& v) { return v * s; }
constexpr double dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
constexpr Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double length(const Vec3& v) { return std::sqrt(dot(v, v)); }
inline Vec3 normalize(const Vec3& v) { return v / length(v); }
inline bool is_finite(const Vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// Local shading frame: the normal is +z. These read the spherical coordinates of a unit vector in that frame.
namespace local {
inline double cos_theta(const Vec3& w) { return w.z; }
inline double cos2_theta(const Vec3& w) { return w.z * w.z; }
inline double sin2_theta(const Vec3& w) { return std::fmax(0.0, 1.0 - w.z * w.z); }
inline double sin_theta(const Vec3& w) { return std::sqrt(sin2_theta(w)); }
inline double tan2_theta(const Vec3& w) { return sin2_theta(w) / cos2_theta(w); }
// Azimuth of w; the normal itself (sin θ = 0) has no azimuth and reads as φ = 0.
inline double cos_phi(const Vec3& w) {
  const double s = sin_theta(w);
  return s == 0.0 ? 1.0 : std::fmax(-1.0, std::fmin(1.0, w.x / s));
}
inline double sin_phi(const Vec3& w) {
  const double s = sin_theta(w);
  return s == 0.0 ? 0.0 : std::fmax(-1.0, std::fmin(1.0, w.y / s));
}
inline bool same_hemisphere(const Vec3& a, const Vec3& b) { return a.z * b.z > 0; }
}  // namespace local

// An orthonormal frame (s, t, n) around a unit normal (Duff et al. 2017, "Building an orthonormal basis, revisited").
struct Frame {
  Vec3 s, t, n;

  static Frame from_normal(const Vec3& n) {
    const double sign = std::copysign(1.0, n.z);
    const double a = -1.0 / (sign + n.z);
    const double b = n.x * n.y * a;
    return {Vec3{1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x}, Vec3{b, sign + n.y * n.y * a, -n.y}, n};
  }
  Vec3 to_local(const Vec3& v) const { return {dot(v, s), dot(v, t), dot(v, n)}; }
  Vec3 from_local(const Vec3& v) const { return s * v.x + t * v.y + n * v.z; }
};

}  // namespace kiln
