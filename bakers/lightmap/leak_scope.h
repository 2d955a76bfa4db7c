// Which sample points can leak (leaks.h), decided from the scene's geometry before any probe ray, so that the probes
// (rings × sectors rays a point) go only where they can find something: on a lone terrain they found nothing, and
// cost a 1 M-triangle terrain at 1024² its whole 30 s time limit.
//
// A probe finds a leak when the point's rays see mostly back faces: the point lies inside or behind geometry. The
// back faces are either its own instance's or another instance's:
//   - Another instance J can put a point p inside or behind it only where p lies in or near J: a point outside the
//     box of a closed mesh is outside the mesh and sees its front faces; an open surface (a one-sided wall) seen
//     from behind hides the points just behind it, within `margin_texels` texel sizes (a texel straddling it).
//     Back faces of J farther away are J's open side seen from afar, which a probe would wrongly take for a leak.
//     "Near" is tested against chunks of `chunk_triangles` consecutive triangles of J (in world space): p must lie
//     within the margin of the chunk's box, and behind or within the margin of the plane of one of its triangles.
//     A ray from a point in front of a triangle's plane can meet only that triangle's front face, so a chunk whose
//     every triangle has p more than the margin in front of it cannot show p a back face. A point on a large
//     terrain is thus probed near the rocks on it but not everywhere in the terrain's box. When J is a height field
//     (below), its surface splits space into above and below: from above, a ray meets its front faces only, so the
//     triangle in p's column decides alone, with no margin beyond the probe's lift (height_field_clearance_texels):
//     a rock on the terrain is probed where it is sunk into the ground, not on its sides above it. Only
//     beside the height field's border, within the margin, do its border triangles' planes judge as for any open
//     mesh. When J is convex and open (a lone wall, a box without a lid), one plane of its with
//     p farther in front than the margin puts p outside all of J by more than that, so then no chunk of J counts.
//     When J is closed and star-shaped (below; a closed convex mesh, such as a crate, is star-shaped about its
//     centroid), only the points inside it: from outside a closed surface a ray meets a front face first, whatever
//     the distance (tested exactly, in J's object space, along the ray from its centre): the ground beside a
//     crate or a rock is not probed, the ground under it is.
//     A point sunk deeper than the boxes of the chunks above it reach is not probed
//     either: it lies under the ground, where no view of the scene sees it.
//   - Its own instance cannot show a point back faces (of the point's hemisphere, where the probe looks) when its
//     mesh is
//       convex: every triangle has the whole mesh on or behind its plane (a plane, a box, a cylinder), so every ray
//       leaving a triangle to its front stays in front of the mesh; or
//       closed and star-shaped: a closed, consistently oriented surface around a centre from which every triangle
//       faces away and which it surrounds once (a rock, a sphere, a statue's rounded body): a point lifted off it
//       is outside the solid, and a ray from outside a closed surface meets a front face first. Except on the
//       triangles of a valley sharper than 90° (two meeting at a point with normals 90° or more apart, one with a
//       corner in front of the other's plane), where a point on the crease lifted along one's normal is behind the
//       other: those triangles' points are probed; or
//       a height field: some direction d has n·d > 0 for every triangle normal n, the triangles' projections along
//       d do not overlap (a terrain), and triangles that meet have normals less than 90° apart; a point lifted off
//       the surface along its triangle's normal is then above the surface (in front of every neighbour's plane too),
//       and a ray from there must cross the surface downwards, through a front face, before it could reach the
//       underside. (A valley sharper than 90° puts a point on its crease, lifted along one side's normal, behind the
//       other side: probed.)
//     Both are properties of the mesh under any affine transform with the same winding, so they are decided once
//     per mesh in object space. Any other mesh (a building whose floor runs under its walls) is probed everywhere.
// A point neither near another instance nor on a mesh that can hide it is clear without a probe.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "bakers/bake/stop.h"
#include "bakers/lightmap/texels.h"
#include "bakers/math/vec3.h"
#include "bakers/scene/scene.h"

namespace kiln::lightmap {

struct LeakScopeOptions {
  double margin_texels = 1.0;  // > 0
  int chunk_triangles = 16;    // ≥ 1
  // How far above a height field a point must be, beyond its ray offset, to be above it: 100 times the probe
  // origin's lift (leaks.h, 1e-4 of a texel), far below a texel.
  double height_field_clearance_texels = 0.01;
};

// How the meshes of the scene's instances were judged.
struct LeakScopeSummary {
  size_t convex_meshes = 0;        // cannot hide their own points: convex
  size_t height_field_meshes = 0;  // cannot hide their own points: a height field
  size_t star_shaped_meshes = 0;   // cannot hide their own points: closed and star-shaped
  size_t valley_triangles = 0;     // of those meshes, the triangles of sharp valleys, probed
  size_t probed_meshes = 0;        // may hide their own points: probed everywhere
  size_t chunks = 0;               // boxes the proximity test holds
};

class LeakScope {
 public:
  // Polls `stop` and throws what its check() throws. The scene must be clean (scene::check_scene's output), and
  // outlive the scope: the chunks' triangles are read from it.
  LeakScope(const scene::Scene& scene, const LeakScopeOptions& options = {}, const bake::StopCheck& stop = {});

  // Per sample: 1 where it may leak and must be probed, 0 where it cannot (above). Parallel, deterministic.
  std::vector<uint8_t> probe_mask(std::span<const TexelSample> samples, const bake::StopCheck& stop = {}) const;

  // Whether mesh m can show its own points back faces (neither convex nor a height field).
  bool self_hiding(int mesh) const { return self_hiding_[static_cast<size_t>(mesh)] != 0; }
  const LeakScopeSummary& summary() const { return summary_; }

 private:
  struct Chunk {
    Vec3 lower, upper;
    uint32_t instance;
    uint32_t first_triangle;  // the chunk holds triangles [first_triangle, first_triangle + triangles)
    uint32_t triangles;
  };
  // A uniform grid over the chunks' boxes, built once: a sample looks up the cells its own reach overlaps.
  struct ChunkGrid {
    Vec3 lower;
    double cell = 1;
    size_t n[3] = {0, 0, 0};      // cells along x, y, z; 0: no grid (no chunks)
    std::vector<uint32_t> first;  // by cell, with one past the last: where its chunks start in `items`
    std::vector<uint32_t> items;  // chunk indices
  };
  void build_grid();
  bool near_other_instance(const TexelSample& s) const;
  bool may_hide(const Chunk& chunk, const TexelSample& s, double margin) const;
  bool height_field_may_hide(const Chunk& chunk, const Vec3& p, double margin, double clearance,
                             const Vec3& up) const;

  const scene::Scene& scene_;
  LeakScopeOptions options_;
  std::vector<int8_t> winding_;       // by instance: +1, or −1 where its transform mirrors (det < 0) the front side
  std::vector<uint8_t> self_hiding_;  // by mesh
  std::vector<uint8_t> convex_;       // by mesh
  std::vector<std::optional<Vec3>> star_centre_;        // by mesh: closed star-shaped meshes' centres (object space)
  std::vector<std::optional<Vec3>> height_up_;          // by mesh: height fields' directions (object space)
  std::vector<std::vector<uint8_t>> border_triangles_;  // by mesh and triangle, of height fields: on the border
  std::vector<scene::Transform> to_object_;             // by instance, of those meshes' instances: world to object
  std::vector<std::vector<uint8_t>> valley_triangles_;  // by mesh and triangle: probed (closed star-shaped meshes)
  std::vector<Chunk> chunks_;
  ChunkGrid grid_;
  LeakScopeSummary summary_;
};

// Exposed for tests: the three mesh properties above (object space, clean mesh).
bool is_convex_mesh(const scene::Mesh& mesh);
bool is_height_field(const scene::Mesh& mesh);
bool is_star_shaped_closed(const scene::Mesh& mesh);
// Its direction d when it is a height field (the mean of its triangles' normals), else nullopt.
std::optional<Vec3> height_field_direction(const scene::Mesh& mesh);
// Its centre when it is closed and star-shaped (the area-weighted centroid of its triangles), else nullopt.
std::optional<Vec3> star_centre(const scene::Mesh& mesh);
// Whether the point q lies inside the closed star-shaped mesh around `centre` (on its surface counts as inside).
bool inside_star_shaped(const scene::Mesh& mesh, const Vec3& centre, const Vec3& q);
// Per triangle, 1 where it is part of a valley sharper than 90°.
std::vector<uint8_t> sharp_valley_triangles(const scene::Mesh& mesh);

}  // namespace kiln::lightmap
