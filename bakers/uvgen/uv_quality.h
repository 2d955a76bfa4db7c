// How good a mesh's lightmap UVs are: the measures the lightmap-UV generator reports and checks its charts against.
//
// - L2 stretch (Sander, Snyder, Gortler, Hoppe, "Texture mapping progressive meshes", SIGGRAPH 2001): per triangle,
//   the root mean square of the singular values Γ, γ of the map from UV to the surface, √((Γ² + γ²)/2); over a mesh,
//   √(Σ A·L2² / Σ A) with A the triangles' surface areas, multiplied by √(Σ A_uv / Σ A) so that a uniform scale of
//   the UVs does not change it. 1 for a map that only rotates and scales uniformly (an isometry up to scale); above 1
//   where texels are stretched over the surface (under-sampled).
// - Mean angle error: |angle in 3-D − angle in UV| averaged over every corner of every triangle, in degrees; 0 for a
//   conformal (angle-preserving) map.
// - Utilisation: the UV area the triangles cover, as a fraction of the unit square (the atlas they are packed in).
// - Flipped: triangles whose UV orientation is the opposite of the majority's (a mirrored or folded piece).
// - Overlaps: pairs of triangles whose UV interiors overlap, by the scene check's test (scene_check.h).
// Triangles the scene check would drop (index out of range, non-finite, or flat at float precision in 3-D:
// mesh_charts.h's chartable) and triangles with no UV area are left out of every measure but the overlaps.
#pragma once

#include <array>
#include <cstdint>
#include <utility>
#include <vector>

#include "bakers/math/sampling.h"
#include "bakers/math/vec3.h"
#include "bakers/scene/scene.h"
#include "bakers/scene/scene_check.h"

namespace kiln::uvgen {

// Running sums of the distortion of UV triangles against their surface triangles.
class DistortionSums {
 public:
  // Adds the triangle with corners p in 3-D and q in UV; a triangle with no area in either is left out.
  void add(const std::array<Vec3, 3>& p, const std::array<Point2, 3>& q);
  double l2_stretch() const;                // normalized as above; 1 when nothing was added
  double mean_angle_error_degrees() const;  // 0 when nothing was added
  double surface_area() const { return area3_; }
  double uv_area() const { return area2_; }
  int64_t triangles() const { return triangles_; }
  int64_t positive() const { return positive_; }  // triangles counter-clockwise in UV

 private:
  double area3_ = 0, area2_ = 0, stretch_ = 0, angle_error_ = 0;
  int64_t triangles_ = 0, positive_ = 0;
};

struct UvQuality {
  int64_t triangles = 0;  // measured
  double l2_stretch = 1;
  double mean_angle_error_degrees = 0;
  double utilisation = 0;
  int64_t flipped = 0;
  int64_t overlaps = 0;
};

// The quality of `mesh.lightmap_uv` (which must hold one UV per position; otherwise nothing is measured).
UvQuality measure_uv_quality(const scene::Mesh& mesh);

// The scene check (scene_check.h) of a scene of this mesh alone, one instance of it baking into a lightmap of its own:
// what the mesh's own lightmap UVs are like, apart from any other instance or mesh.
scene::CheckedScene check_mesh_alone(const scene::Mesh& mesh, size_t max_listed_per_kind);

// The pairs of triangles of `mesh` whose lightmap UVs overlap (at most `max_pairs` of them listed; `count` receives
// every pair found), by the scene check's overlap test. UVs outside [0, 1] are not tested (the scene check does not
// bake them).
std::vector<std::pair<uint32_t, uint32_t>> overlapping_uv_triangles(const scene::Mesh& mesh, size_t max_pairs,
                                                                    int64_t& count);

}  // namespace kiln::uvgen
