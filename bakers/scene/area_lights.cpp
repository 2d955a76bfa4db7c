#include "bakers/scene/area_lights.h"

#include <algorithm>
#include <cmath>

#include "bakers/math/constants.h"
#include "bakers/scene/spherical_geometry.h"

namespace kiln::scene {

namespace {

bool usable_radiance(const Rgb& L) { return !usable_emission(L).is_black(); }

// A point x sampled on a surface by area with density 1/A, seen from p: the sample in solid angle,
// pdf = d² / (A |cos θ_l|). nullopt for x at p or seen exactly edge-on (the density per solid angle is unbounded;
// such a sample carries no light).
std::optional<LightSample> area_sample(const Vec3& p, const Vec3& x, const Vec3& normal, double area, const Rgb& L) {
  const Vec3 d = x - p;
  const double dist2 = dot(d, d);
  if (!(dist2 > 0)) return std::nullopt;
  const double dist = std::sqrt(dist2);
  const Vec3 wi = d / dist;
  const double cos_l = std::fabs(dot(normal, wi));
  if (!(cos_l > 0)) return std::nullopt;
  LightSample s;
  s.wi = wi;
  s.Li = L;
  s.pdf = dist2 / (area * cos_l);
  if (!std::isfinite(s.pdf)) return std::nullopt;
  s.distance = dist;
  s.point = x;
  return s;
}

double area_pdf(const LightHit& hit, const Vec3& wi, const Vec3& normal, double area) {
  const double cos_l = std::fabs(dot(normal, wi));
  if (!(cos_l > 0)) return 0.0;
  const double pdf = hit.distance * hit.distance / (area * cos_l);
  return std::isfinite(pdf) ? pdf : 0.0;
}

}  // namespace

// ---- RectLight ----

RectLight::RectLight(const Vec3& center, const Vec3& u_edge, const Vec3& v_edge, const Vec3& front, const Rgb& radiance,
                     bool two_sided)
    : c0_(center - u_edge * 0.5 - v_edge * 0.5),
      ex_(u_edge),
      ey_(v_edge),
      radiance_(usable_emission(radiance)),
      two_sided_(two_sided) {
  const Vec3 cr = cross(u_edge, v_edge);
  const double a = length(cr);
  // Zero or parallel edges (no area) or unusable radiance: a black light with zero power.
  if (!(a > 0) || !std::isfinite(a) || !is_finite(center) || !usable_radiance(radiance)) {
    area_ = 0;
    radiance_ = Rgb{};
    normal_ = Vec3{0, 0, 1};
    return;
  }
  area_ = a;
  normal_ = cr / a;
  if (dot(front, normal_) < 0) normal_ = -normal_;
  const double lu = length(u_edge), lv = length(v_edge);
  // Orthogonal to rounding: the spherical parametrisation assumes a right angle at every corner.
  orthogonal_ = std::fabs(dot(u_edge, v_edge)) <= 1e-12 * lu * lv;
}

Vec3 RectLight::corner(int i) const {
  switch (i & 3) {
    case 0:
      return c0_;
    case 1:
      return c0_ + ex_;
    case 2:
      return c0_ + ex_ + ey_;
    default:
      return c0_ + ey_;
  }
}

bool RectLight::lit_side(const Vec3& p) const {
  if (area_ == 0) return false;
  const double h = dot(p - c0_, normal_);
  // h = 0: p on the light's plane sees it edge-on (no solid angle), whichever sides emit.
  return two_sided_ ? h != 0 : h > 0;
}

double RectLight::solid_angle(const Vec3& p) const {
  if (area_ == 0 || dot(p - c0_, normal_) == 0) return 0.0;  // on the plane: edge-on
  const Vec3 a = corner(0) - p, b = corner(1) - p, c = corner(2) - p, d = corner(3) - p;
  return triangle_solid_angle(a, b, c) + triangle_solid_angle(a, c, d);
}

bool RectLight::uses_spherical_sampling(const Vec3& p) const {
  return orthogonal_ && solid_angle(p) >= kMinSphericalSolidAngle;
}

std::optional<LightSample> RectLight::sample_li(const Vec3& p, const Vec3& /*n*/, Point2 u) const {
  if (!lit_side(p)) return std::nullopt;
  if (orthogonal_) {
    const double omega = solid_angle(p);
    if (omega >= kMinSphericalSolidAngle) return sample_spherical(p, u, omega);
  }
  return area_sample(p, c0_ + ex_ * u.x + ey_ * u.y, normal_, area_, radiance_);
}

std::optional<LightSample> RectLight::sample_spherical(const Vec3& p, Point2 u, double omega) const {
  // Ureña et al. 2013, §3: in the frame (x̂, ŷ, ẑ) with x̂, ŷ along the edges and the rectangle at z = z0 < 0, the
  // rectangle spans [x0, x1] × [y0, y1]. u₀ picks the cut x = xu so that the solid angle left of it is u₀ Ω (the
  // spherical-quad area formula inverted in closed form); u₁ then picks y uniformly in the solid angle of that strip
  // through h = y / sqrt(xu² + z0² + y²).
  const double exl = length(ex_), eyl = length(ey_);
  const Vec3 xh = ex_ / exl, yh = ey_ / eyl;
  Vec3 zh = cross(xh, yh);
  const Vec3 d = c0_ - p;
  const double x0 = dot(d, xh), y0 = dot(d, yh);
  double z0 = dot(d, zh);
  if (z0 > 0) {  // make the rectangle lie below p along ẑ
    zh = -zh;
    z0 = -z0;
  }
  const double x1 = x0 + exl, y1 = y0 + eyl;
  const Vec3 v00{x0, y0, z0}, v01{x0, y1, z0}, v10{x1, y0, z0}, v11{x1, y1, z0};
  // Normals of the planes through p and each edge; the quad's interior angles are between consecutive ones.
  const Vec3 n0 = normalize(cross(v00, v10)), n1 = normalize(cross(v10, v11));
  const Vec3 n2 = normalize(cross(v11, v01)), n3 = normalize(cross(v01, v00));
  const double g0 = angle_between(-n0, n1), g1 = angle_between(-n1, n2);
  const double g2 = angle_between(-n2, n3), g3 = angle_between(-n3, n0);
  const double b0 = n0.z, b1 = n2.z;
  // au = u₀ S + k with S = Σg − 2π and k = 2π − g2 − g3, written as in pbrt-v4 (the same angle modulo 2π).
  const double au = u.x * (g0 + g1 - 2.0 * kPi) + (u.x - 1.0) * (g2 + g3);
  const double sin_au = std::sin(au);
  double xu;
  // sin(au) = 0 happens only at u₀ ∈ {0, 1} up to rounding: the cut is then the rectangle's left or right edge.
  if (sin_au == 0.0) {
    xu = u.x < 0.5 ? x0 : x1;
  } else {
    const double fu = (std::cos(au) * b0 - b1) / sin_au;
    double cu = std::copysign(1.0 / std::sqrt(fu * fu + b0 * b0), fu);
    cu = std::clamp(cu, -kOneMinusEpsilon, kOneMinusEpsilon);
    xu = -(cu * z0) / std::sqrt(std::fmax(0.0, 1.0 - cu * cu));
    xu = std::isfinite(xu) ? std::clamp(xu, x0, x1) : (u.x < 0.5 ? x0 : x1);
  }
  const double dd = std::sqrt(xu * xu + z0 * z0);
  const double h0 = y0 / std::sqrt(dd * dd + y0 * y0), h1 = y1 / std::sqrt(dd * dd + y1 * y1);
  const double hv = h0 + u.y * (h1 - h0), hv2 = hv * hv;
  // hv² → 1 only when the strip's far end is at infinity along y, impossible for a finite rectangle; the guard keeps
  // yv finite whatever rounding does.
  const double yv = hv2 < 1.0 ? std::clamp(hv * dd / std::sqrt(1.0 - hv2), y0, y1) : y1;
  const Vec3 local = xh * xu + yh * yv + zh * z0;
  const double dist = length(local);
  if (!(dist > 0) || !std::isfinite(dist)) return std::nullopt;
  LightSample s;
  s.wi = local / dist;
  s.Li = radiance_;
  s.pdf = 1.0 / omega;
  s.distance = dist;
  s.point = p + local;
  return s;
}

std::optional<LightHit> RectLight::intersect(const Vec3& p, const Vec3& wi, double t_max) const {
  if (area_ == 0) return std::nullopt;
  const double denom = dot(wi, normal_);
  if (denom == 0) return std::nullopt;  // the ray runs parallel to the plane
  const double t = dot(c0_ - p, normal_) / denom;
  if (!(t > 0 && t < t_max) || !std::isfinite(t)) return std::nullopt;
  const Vec3 x = p + wi * t;
  // Coordinates along the (possibly non-orthogonal) edges through the dual basis in the plane.
  const Vec3 r = x - c0_;
  const Vec3 du = cross(ey_, normal_), dv = cross(normal_, ex_);
  const double a = dot(r, du) / dot(ex_, du), b = dot(r, dv) / dot(ey_, dv);
  if (!(a >= 0 && a <= 1 && b >= 0 && b <= 1)) return std::nullopt;
  LightHit hit;
  hit.point = x;
  hit.normal = normal_;
  hit.distance = t;
  return hit;
}

double RectLight::pdf_li(const Vec3& p, const Vec3& /*n*/, const Vec3& wi, const LightHit& /*hit*/) const {
  if (!lit_side(p)) return 0.0;
  const auto hit = intersect(p, wi, kInfinity);
  if (!hit) return 0.0;
  if (orthogonal_) {
    const double omega = solid_angle(p);
    if (omega >= kMinSphericalSolidAngle) return 1.0 / omega;
  }
  return area_pdf(*hit, wi, normal_, area_);
}

Rgb RectLight::Le(const Vec3& /*p*/, const Vec3& wi, const LightHit& /*hit*/) const {
  const double c = dot(normal_, -wi);  // > 0: the ray arrives at the front side
  return (c > 0 || (two_sided_ && c < 0)) ? radiance_ : Rgb{};
}

Rgb RectLight::power(double /*scene_radius*/) const {
  // Lambertian emitter: π L A per emitting side.
  return radiance_ * (kPi * area_ * (two_sided_ ? 2.0 : 1.0));
}

// ---- DiskLight ----

DiskLight::DiskLight(const Vec3& center, const Vec3& normal, double radius, const Rgb& radiance, bool two_sided)
    : center_(center), radius_(radius), radiance_(usable_emission(radiance)), two_sided_(two_sided) {
  const double ln = length(normal);
  area_ = kPi * radius * radius;
  // Zero radius, no normal or unusable radiance: a black light with zero power.
  if (!(radius > 0) || !std::isfinite(area_) || !(area_ > 0) || !(ln > 0) || !std::isfinite(ln) || !is_finite(center) ||
      !usable_radiance(radiance)) {
    area_ = 0;
    radius_ = 0;
    radiance_ = Rgb{};
    frame_ = Frame::from_normal({0, 0, 1});
    return;
  }
  frame_ = Frame::from_normal(normal / ln);
}

bool DiskLight::lit_side(const Vec3& p) const {
  if (area_ == 0) return false;
  const double h = dot(p - center_, frame_.n);
  return two_sided_ ? h != 0 : h > 0;  // h = 0: p on the light's plane, edge-on
}

std::optional<LightSample> DiskLight::sample_li(const Vec3& p, const Vec3& /*n*/, Point2 u) const {
  if (!lit_side(p)) return std::nullopt;
  const Point2 d = sample_concentric_disk(u);
  const Vec3 x = center_ + (frame_.s * d.x + frame_.t * d.y) * radius_;
  return area_sample(p, x, frame_.n, area_, radiance_);
}

std::optional<LightHit> DiskLight::intersect(const Vec3& p, const Vec3& wi, double t_max) const {
  if (area_ == 0) return std::nullopt;
  const double denom = dot(wi, frame_.n);
  if (denom == 0) return std::nullopt;  // parallel to the plane
  const double t = dot(center_ - p, frame_.n) / denom;
  if (!(t > 0 && t < t_max) || !std::isfinite(t)) return std::nullopt;
  const Vec3 x = p + wi * t;
  const Vec3 r = x - center_;
  const double a = dot(r, frame_.s), b = dot(r, frame_.t);
  if (!(a * a + b * b <= radius_ * radius_)) return std::nullopt;
  LightHit hit;
  hit.point = x;
  hit.normal = frame_.n;
  hit.distance = t;
  return hit;
}

double DiskLight::pdf_li(const Vec3& p, const Vec3& /*n*/, const Vec3& wi, const LightHit& /*hit*/) const {
  if (!lit_side(p)) return 0.0;
  const auto hit = intersect(p, wi, kInfinity);
  return hit ? area_pdf(*hit, wi, frame_.n, area_) : 0.0;
}

Rgb DiskLight::Le(const Vec3& /*p*/, const Vec3& wi, const LightHit& /*hit*/) const {
  const double c = dot(frame_.n, -wi);
  return (c > 0 || (two_sided_ && c < 0)) ? radiance_ : Rgb{};
}

Rgb DiskLight::power(double /*scene_radius*/) const { return radiance_ * (kPi * area_ * (two_sided_ ? 2.0 : 1.0)); }

// ---- Light tracing ----

std::optional<LightEmission> RectLight::sample_le(Point2 u_position, Point2 u_direction) const {
  if (area_ == 0) return std::nullopt;
  LightEmission e;
  e.origin = c0_ + ex_ * u_position.x + ey_ * u_position.y;
  const std::optional<double> factor = lambertian_emission(normal_, two_sided_, u_direction, e);
  if (!factor) return std::nullopt;
  e.weight = radiance_ * (*factor * area_);
  return e;
}

std::optional<LightEmission> DiskLight::sample_le(Point2 u_position, Point2 u_direction) const {
  if (area_ == 0) return std::nullopt;
  LightEmission e;
  const Point2 d = sample_concentric_disk(u_position);
  e.origin = center_ + (frame_.s * d.x + frame_.t * d.y) * radius_;
  const std::optional<double> factor = lambertian_emission(frame_.n, two_sided_, u_direction, e);
  if (!factor) return std::nullopt;
  e.weight = radiance_ * (*factor * area_);
  return e;
}

}  // namespace kiln::scene
