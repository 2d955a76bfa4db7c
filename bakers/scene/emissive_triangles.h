// Emissive triangles as one light: the world-space triangles of every mesh whose material has emission > 0, each
// emitting its material's L_e from its front side (the side of (p1 − p0) × (p2 − p0)) unless two-sided.
//
// sample_li chooses a triangle in proportion to its power (area × luminance(L_e), × 2 if two-sided) through an
// alias table — the same as choosing among them as separate lights by power — and then a point uniformly by
// area (Heitz 2019's low-distortion square-to-triangle map), converted to solid angle: pdf = pmf · d² / (A |cos θ_l|).
// pdf_li needs the triangle a ray hit (LightHit::triangle, from find()) and includes its pmf.
//
// Singular cases: triangles with non-finite vertices or zero area are left out (they emit nothing a ray can hit);
// p on a triangle's plane or behind a one-sided triangle gets no light from it (sample_li: nullopt, pdf_li: 0).
#pragma once

#include <bit>
#include <cmath>
#include <cstdint>
#include <optional>
#include <vector>

#include "bakers/scene/alias_table.h"
#include "bakers/scene/lights.h"
#include "bakers/scene/scene.h"

namespace kiln::scene {

struct EmissiveTriangle {
  Vec3 p0, p1, p2;  // world space, counter-clockwise seen from the front
  Rgb Le;
  bool two_sided = false;
  int instance = -1, triangle = -1;  // where it came from in the Scene (for find); −1 when built by hand
};

class EmissiveTriangles final : public LightSource {
 public:
  explicit EmissiveTriangles(std::vector<EmissiveTriangle> triangles);
  // Every emissive triangle of every instance, in world space. An instance whose transform mirrors (negative
  // determinant) has its triangles' winding reversed so that the front side stays the outside the mesh was modelled
  // with. Triangles with indices or materials out of range are skipped (the scene's validation reports those).
  static EmissiveTriangles from_scene(const Scene& scene);

  LightSamplerKind kind() const override { return LightSamplerKind::emissive_triangles; }
  std::optional<LightSample> sample_li(const Vec3& p, const Vec3& n, Point2 u) const override;
  // sample_li itself (it does not depend on n), defined inline below for next-event estimation's hot loop: called
  // directly on the container, it inlines, so its result never goes through memory (as a virtual call's must).
  [[gnu::always_inline]] std::optional<LightSample> sample(const Vec3& p, Point2 u) const;
  // hit.triangle: the container's index; hit.point: where the ray met it.
  double pdf_li(const Vec3& p, const Vec3& n, const Vec3& wi, const LightHit& hit) const override;
  Rgb Le(const Vec3& p, const Vec3& wi, const LightHit& hit) const override;
  Rgb power(double scene_radius) const override;
  // A triangle by power (the alias table's choice, from u_position.x), a point uniform on it, a Lambertian direction.
  bool emits_rays() const override { return !empty(); }
  std::optional<LightEmission> sample_le(Point2 u_position, Point2 u_direction) const override;

  int size() const { return static_cast<int>(triangles_.size()); }
  bool empty() const { return triangles_.empty(); }
  const EmissiveTriangle& triangle(int i) const { return triangles_[i]; }
  double area(int i) const { return area_[i]; }
  double pmf(int i) const { return choice_.pmf(i); }
  // The container's index of triangle `triangle` of instance `instance`, or −1 if it does not emit.
  int find(int instance, int triangle) const;

 private:
  // What sample_li reads of one triangle, together: its vertex p2 and the edges to the other two (x = p2 + b0·e0 +
  // b1·e1), the unit front normal (pdf_li and Le read it too), 1/area and the emission.
  struct Sampling {
    Vec3 p2, e0, e1, ng;
    double inv_area;
    Rgb Le;
    bool two_sided;
  };
  std::vector<EmissiveTriangle> triangles_;
  std::vector<double> area_;
  std::vector<Sampling> sampling_;
  AliasTable choice_;
  // find()'s table, dense: per instance, the container's index of triangles first … first + size − 1 of it (the span
  // of its emissive triangles; −1 for those between that do not emit). A lookup per path vertex that hits an emitter,
  // so two loads rather than a hash; at most one int per triangle of an emissive mesh (the tracer keeps 120 bytes).
  struct InstanceIndex {
    int first = 0;
    std::vector<int> index;
  };
  std::vector<InstanceIndex> index_;
  Rgb power_;
};

inline std::optional<LightSample> EmissiveTriangles::sample(const Vec3& p, Point2 u) const {
  if (sampling_.empty()) return std::nullopt;
  const AliasTable::Choice choice = choice_.sample(u.x);
  const Sampling& t = sampling_[choice.index];
  const double h = dot(p - t.p2, t.ng);
  // p on the triangle's plane (edge-on) or behind a one-sided triangle: no light from it.
  if (t.two_sided ? h == 0 : !(h > 0)) return std::nullopt;
  // Heitz 2019, "A low-distortion map between triangle and square": uniform barycentrics b0, b1 of p0, p1; with
  // a = min(ux, uy) and b = max: (a/2, b − a/2) if ux < uy, else (b − a/2, a/2). Chosen by a bit mask rather than
  // a branch (which the compiler makes of a conditional): which of ux, uy is smaller is a coin toss on every call.
  const double ux = choice.u_remapped, uy = u.y;
  const uint64_t first = uint64_t{0} - static_cast<uint64_t>(ux < uy);  // all ones when ux < uy
  auto pick = [first](double if_first, double otherwise) {
    return std::bit_cast<double>((std::bit_cast<uint64_t>(if_first) & first) |
                                 (std::bit_cast<uint64_t>(otherwise) & ~first));
  };
  const double half = 0.5 * pick(ux, uy), rest = pick(uy, ux) - half;
  const double b0 = pick(half, rest), b1 = pick(rest, half);
  const Vec3 x = t.p2 + t.e0 * b0 + t.e1 * b1;
  const Vec3 d = x - p;
  const double dist2 = dot(d, d);
  // |ng·d| = cos θ_l · dist.
  const double c = std::fabs(dot(t.ng, d));
  // p is the sampled point itself, or sees it exactly edge-on: no light along d.
  if (!(dist2 > 0) || !(c > 0)) return std::nullopt;
  const double dist = std::sqrt(dist2);
  // One division serves both wi = d / dist and the density pmf · dist² / (A cos θ_l) = pmf · dist⁴ / (A · dist · c):
  // this runs at every path vertex.
  const double r = 1.0 / (dist * c);
  LightSample s;
  s.wi = d * (c * r);
  s.Li = t.Le;
  s.pdf = choice.pmf * t.inv_area * (dist2 * dist2) * r;
  if (!std::isfinite(s.pdf)) return std::nullopt;
  s.distance = dist;
  s.point = x;
  return s;
}

}  // namespace kiln::scene
