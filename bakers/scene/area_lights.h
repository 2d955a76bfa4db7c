// Rectangle and disk area lights: emitted radiance L_e, uniform over the surface, from the front side (the side the
// light's `direction` points to) unless two-sided. They are analytic shapes, not scene geometry: the integrator
// finds BSDF rays that reach them with intersect().
//
// Sampling (per unit solid angle at p):
// - Rect: spherical rectangle sampling (Ureña, Fajardo & King 2013, "An area-preserving parametrization for spherical
//   rectangles"), which is uniform in the solid angle Ω the rectangle subtends: pdf = 1/Ω. It needs orthogonal edges
//   and a solid angle the algorithm resolves in double precision; a parallelogram (u_axis·v_axis ≠ 0) or a rectangle
//   subtending less than kMinSphericalSolidAngle is sampled uniformly by area with pdf = d² / (A |cos θ_l|). The
//   choice depends only on the light and p, so sample_li and pdf_li always describe the same strategy.
// - Disk: uniformly by area through the concentric map, pdf = d² / (A |cos θ_l|).
// Ω is computed as two Van Oosterom–Strackee triangles (spherical_geometry.h), accurate for tiny rectangles.
//
// Singular cases, each guarded where it arises: p on the light's plane (no solid angle: no light, pdf 0), p behind
// a one-sided light (no light), a sample seen exactly edge-on (|cos θ_l| = 0: dropped), zero area, zero radius,
// zero or parallel edges (a black light with zero power), a black L_e.
#pragma once

#include "bakers/scene/lights.h"
#include "bakers/scene/scene.h"

namespace kiln::scene {

class RectLight final : public LightSource {
 public:
  // Below this solid angle (sr) the rectangle is sampled by area: the spherical parametrisation's angle sums cancel
  // to Ω with an absolute error near 1e-15, i.e. a relative error ≤ 1e-10 at 1e-5 sr, while area sampling of so
  // small a light is already nearly uniform in solid angle.
  static constexpr double kMinSphericalSolidAngle = 1e-5;

  // center, full edge vectors u_edge and v_edge, `front` (any vector on the emitting side; need not be normal to
  // the plane: only its side counts; zero = the side of u_edge × v_edge).
  RectLight(const Vec3& center, const Vec3& u_edge, const Vec3& v_edge, const Vec3& front, const Rgb& radiance,
            bool two_sided);
  LightSamplerKind kind() const override { return LightSamplerKind::rect; }
  std::optional<LightSample> sample_li(const Vec3& p, const Vec3& n, Point2 u) const override;
  double pdf_li(const Vec3& p, const Vec3& n, const Vec3& wi, const LightHit& hit) const override;
  Rgb Le(const Vec3& p, const Vec3& wi, const LightHit& hit) const override;
  std::optional<LightHit> intersect(const Vec3& p, const Vec3& wi, double t_max) const override;
  Rgb power(double scene_radius) const override;
  bool emits_rays() const override { return area_ > 0; }
  std::optional<LightEmission> sample_le(Point2 u_position, Point2 u_direction) const override;

  double area() const { return area_; }
  // The solid angle the whole rectangle subtends at p (0 on its plane).
  double solid_angle(const Vec3& p) const;
  // True when p would be sampled with the spherical rectangle parametrisation.
  bool uses_spherical_sampling(const Vec3& p) const;
  bool uniform_in_solid_angle(const Vec3& p) const override { return uses_spherical_sampling(p); }
  // Corners in order c0, c0 + u, c0 + u + v, c0 + v (counter-clockwise seen from the side of u × v).
  Vec3 corner(int i) const;

 private:
  bool lit_side(const Vec3& p) const;  // p strictly on an emitting side
  std::optional<LightSample> sample_spherical(const Vec3& p, Point2 u, double omega) const;
  Vec3 c0_, ex_, ey_;  // corner and edges
  Vec3 normal_;        // unit, towards the front side
  Rgb radiance_;
  bool two_sided_ = false;
  bool orthogonal_ = false;
  double area_ = 0;
};

class DiskLight final : public LightSource {
 public:
  DiskLight(const Vec3& center, const Vec3& normal, double radius, const Rgb& radiance, bool two_sided);
  LightSamplerKind kind() const override { return LightSamplerKind::disk; }
  std::optional<LightSample> sample_li(const Vec3& p, const Vec3& n, Point2 u) const override;
  double pdf_li(const Vec3& p, const Vec3& n, const Vec3& wi, const LightHit& hit) const override;
  Rgb Le(const Vec3& p, const Vec3& wi, const LightHit& hit) const override;
  std::optional<LightHit> intersect(const Vec3& p, const Vec3& wi, double t_max) const override;
  Rgb power(double scene_radius) const override;
  bool emits_rays() const override { return area_ > 0; }
  std::optional<LightEmission> sample_le(Point2 u_position, Point2 u_direction) const override;
  double area() const { return area_; }

 private:
  bool lit_side(const Vec3& p) const;
  Vec3 center_;
  Frame frame_;  // n = the front normal
  double radius_ = 0, area_ = 0;
  Rgb radiance_;
  bool two_sided_ = false;
};

}  // namespace kiln::scene
