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

#include <cstdint>
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

  LightKind kind() const override { return LightKind::emissive_triangles; }
  std::optional<LightSample> sample_li(const Vec3& p, const Vec3& n, Point2 u) const override;
  // hit.triangle: the container's index; hit.point: where the ray met it.
  double pdf_li(const Vec3& p, const Vec3& n, const Vec3& wi, const LightHit& hit) const override;
  Rgb Le(const Vec3& p, const Vec3& wi, const LightHit& hit) const override;
  Rgb power(double scene_radius) const override;

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
  // so two loads rather than a hash; at most one int per triangle of an emissive mesh (the tracer keeps 128 bytes).
  struct InstanceIndex {
    int first = 0;
    std::vector<int> index;
  };
  std::vector<InstanceIndex> index_;
  Rgb power_;
};

}  // namespace kiln::scene
