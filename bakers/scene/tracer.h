// Ray tracing a cleaned scene (scene_check.h) with Embree. Embree stays behind this header (pimpl).
//
// Geometry, two ways (TracerOptions::instancing):
//   - Flattened: an instance whose mesh no other instance uses is one Embree triangle geometry of its own, its
//     vertices transformed to world space in double and rounded to float once. One level of BVH traces faster than
//     two (no per-instance ray transform, no overlapping instance boxes for the SAH to work around), and the float
//     error of a hit is that of one float triangle in world space, which ray_offset.h bounds exactly.
//   - Instanced: a mesh used by several instances (enough to matter: Instancing::shared) is one BVH of its own (its vertices rounded to float in object
//     space), and each instance is an Embree instance geometry (RTC_GEOMETRY_TYPE_INSTANCE) of it with the instance's
//     transform rounded to float: a level of 10,000 instances of a few hundred meshes holds each mesh once. Embree
//     transforms the ray into object space in float, so the offset of a hit (Hit::offset) adds a bound on that
//     transform's error to the object-space bound (tracer.cpp, instance_offset); hit points, normals and offsets are
//     otherwise computed in double in world space as for flattened geometry.
// Both in a single top-level BVH built with RTC_BUILD_QUALITY_HIGH. RTC_SCENE_FLAG_ROBUST by default: watertight
// edges, so light does not leak through the seams of closed rooms.
//
// Thread safety: every query is const and uses its own RTCIntersectContext; any number of threads may trace at once.
// The Tracer keeps what it needs (float vertices, indices, normals, UVs, transforms): the Scene may go away.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>

#include "bakers/bake/stop.h"
#include "bakers/math/sampling.h"
#include "bakers/math/vec3.h"
#include "bakers/scene/ray_offset.h"
#include "bakers/scene/scene.h"

namespace kiln::scene {

// What a closest-hit query finds, in world space. Barycentrics: p = (1 − u − v)·p0 + u·p1 + v·p2 over the triangle's
// indices in order.
struct Hit {
  double t = 0;      // along the ray, in units of |direction|
  int instance = 0;  // into scene.instances
  int mesh = 0;      // into scene.meshes
  int triangle = 0;  // into that mesh's triangles
  int material = 0;  // into scene.materials (the mesh's material of that triangle)
  double u = 0, v = 0;
  Vec3 p;              // the hit point, interpolated in double from the float vertices Embree traced
  Vec3 ng;             // unit geometric normal on the front side ((p1 − p0) × (p2 − p0), mirrored instances kept
                       // outward: the normal transformed by the inverse transpose)
  Vec3 ns;             // unit shading normal: interpolated vertex normals transformed by the inverse transpose,
                       // on ng's side (flipped if the mesh's normals disagree with its winding); ng without them
  Point2 lightmap_uv;  // in the instance's lightmap (lightmap_scale_offset applied); (0,0) without lightmap UVs
                       // or when not asked for (HitDetail)
  Point2 uv;           // texture UV set 0; (0,0) without, or when not asked for
  bool front_face = true;  // the ray arrived from ng's side
  double offset = 0;       // lift off the surface that clears its float error (ray_offset.h)

  SurfacePoint surface() const { return {p, ng, offset}; }
};

// The least a closest-hit query can report: for queries that need the distance or the triangle only.
struct HitId {
  double t = 0;
  int instance = 0, triangle = 0;
  double u = 0, v = 0;
  bool front_face = true;
};

// What a closest-hit query interpolates beyond the hit's place, normals and offset (which it always gives): path
// vertices need no lightmap UVs, and texture UVs only where a texture is sampled.
struct HitDetail {
  bool lightmap_uv = true;
  bool uv = true;
};

// Which meshes go to Embree once, as instances of one BVH (above).
enum class Instancing {
  // Meshes used by several instances whose copies would hold at least kInstancingMinCopies triangles beyond the
  // first (the default). Two-level traversal costs rays ~20-30 % where they meet instances (tracer_bench's room),
  // which buys little when the copies are small; a single-use mesh is always flattened.
  shared,
  none,    // every instance flattened (the world-space copy of each mesh per instance)
  all,     // every mesh, even one used once (for measurements)
};

// Instancing::shared's threshold: triangles × (instances − 1) of a mesh, ~1 MB of flattened copies.
inline constexpr size_t kInstancingMinCopies = 4096;

// Whether the tracer holds a mesh of `triangles` traced by `uses` instances once, as an instance of one BVH, rather
// than a world-space copy per instance (the rule of `instancing` above; memory estimates apply it too).
inline bool instanced_mesh(Instancing instancing, size_t uses, size_t triangles) {
  const size_t copies = uses > 1 ? (uses - 1) * triangles : 0;
  return instancing == Instancing::all ? uses > 0 : instancing == Instancing::shared ? copies >= kInstancingMinCopies
                                                                                      : false;
}

struct TracerOptions {
  bool robust = true;  // RTC_SCENE_FLAG_ROBUST (watertight); false trades that for ~speed
  Instancing instancing = Instancing::shared;
  // Polled while the tracer copies the geometry (every 65536 triangles) and while Embree builds the BVH (its progress
  // monitor, which cancels the build); the constructor then throws what stop->check() throws. Null: never stops.
  const bake::StopCheck* stop = nullptr;
};

class Tracer {
 public:
  // `scene` must be clean (check_scene's output): throws std::invalid_argument naming the mesh, instance and
  // triangle otherwise; std::runtime_error with Embree's message if Embree fails (e.g. out of memory).
  explicit Tracer(const Scene& scene, const TracerOptions& options = {});
  ~Tracer();
  Tracer(Tracer&&) noexcept;
  Tracer& operator=(Tracer&&) noexcept;
  Tracer(const Tracer&) = delete;
  Tracer& operator=(const Tracer&) = delete;

  std::optional<Hit> intersect(const Ray& ray, HitDetail detail = {}) const;
  // The same into `out` (untouched on a miss): for loops that reuse one record per path vertex.
  bool intersect(const Ray& ray, Hit& out, HitDetail detail = {}) const;
  std::optional<HitId> intersect_id(const Ray& ray) const;
  // True if anything lies on the ray within (0, tmax].
  bool occluded(const Ray& ray) const;
  bool occluded(const Vec3& origin, const Vec3& direction, double tmax) const {
    return occluded(Ray{origin, direction, tmax});
  }
  // Streams (Embree's rtcIntersect1M / rtcOccluded1M, flagged incoherent); `out` has the size of `rays`.
  void intersect(std::span<const Ray> rays, std::span<std::optional<HitId>> out) const;
  void occluded(std::span<const Ray> rays, std::span<uint8_t> out) const;

  // The full hit record for a HitId of the ray it came from.
  Hit complete(const Ray& ray, const HitId& id) const;

  // The lift off instance `instance`'s triangle `triangle` that clears the tracer's float error there: what a Hit on
  // it reports as `offset`. For a flattened instance it equals self_intersection_offset of its float world vertices;
  // for an instanced one it also covers Embree's float ray transform. Throws std::out_of_range for a triangle the
  // tracer does not hold.
  double ray_offset(int instance, int triangle) const;
  // Whether instance `instance` is traced as an Embree instance (false: flattened, or no triangles).
  bool instanced(int instance) const;

  // Triangles traced, in world space: every instance's (instanced ones counted once per instance).
  size_t triangle_count() const;
  // Triangles held: those of flattened instances, and each instanced mesh's once.
  size_t stored_triangle_count() const;
  // Instances traced as Embree instances, and the meshes they share.
  size_t instanced_instance_count() const;
  size_t instanced_mesh_count() const;
  // Memory the tracer holds: Embree's (its BVHs, an instanced mesh's once, vertex and index buffers and instance
  // geometries, from its memory monitor) and the tracer's own per-triangle, per-vertex and per-instance arrays.
  size_t memory_bytes() const;
  // World-space bounds of everything traced (empty: lower > upper).
  Vec3 bounds_lower() const;
  Vec3 bounds_upper() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace kiln::scene
