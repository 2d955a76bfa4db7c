// Leak handling's ray query (leaks.h) answered by the Embree tracer (bakers/scene/tracer.h), and the samples' ray
// offsets matched to the tracer's.
#pragma once

#include "bakers/lightmap/leaks.h"
#include "bakers/lightmap/ray_log.h"
#include "bakers/scene/scene.h"
#include "bakers/scene/tracer.h"

namespace kiln::lightmap {

// front_face is the tracer's (the ray arrived from the side of the front normal), except that surfaces of two-sided
// materials have no back: every hit on them is a front-face hit. Both references must outlive the query; `scene` is
// the one the tracer was built from (check_scene's cleaned scene), so that hit triangles index its meshes. `log`
// (benchmarks only, ray_log.h) receives every query as a probe.
class TracerRayQuery final : public RayQuery {
 public:
  TracerRayQuery(const scene::Tracer& tracer, const scene::Scene& scene, RayLog* log = nullptr)
      : tracer_(tracer), scene_(scene), log_(log) {}
  std::optional<HitInfo> intersect(const Vec3& origin, const Vec3& dir, double tmax) const override;

 private:
  bool two_sided(int instance, int triangle) const;

  const scene::Tracer& tracer_;
  const scene::Scene& scene_;
  RayLog* log_;
};

// Raises the ray offset of the samples on instanced instances (scene::Tracer::instanced) to the tracer's bound
// there (Tracer::ray_offset), which also covers Embree's float ray transform; rasterization computes the flattened
// bound, the same as the tracer's for flattened instances, which are left as they are.
void match_tracer_offsets(LightmapTexels& texels, const scene::Tracer& tracer);

}  // namespace kiln::lightmap
