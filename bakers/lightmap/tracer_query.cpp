#include "bakers/lightmap/tracer_query.h"

#include <algorithm>
#include <cmath>

namespace kiln::lightmap {

bool TracerRayQuery::two_sided(int instance, int triangle) const {
  const scene::Mesh& mesh = scene_.meshes[scene_.instances[instance].mesh];
  const size_t material = mesh.material.empty() ? 0 : mesh.material[triangle];
  return material < scene_.materials.size() && scene_.materials[material].two_sided;
}

std::optional<HitInfo> TracerRayQuery::intersect(const Vec3& origin, const Vec3& dir, double tmax) const {
  const scene::Ray ray{origin, dir, tmax};
  if (log_) log_->record(ray, RayKind::probe);
  const std::optional<scene::HitId> id = tracer_.intersect_id(ray);
  if (!id) return std::nullopt;
  if (id->front_face || two_sided(id->instance, id->triangle)) return HitInfo{id->t, true, {}};
  // Only a back-face hit needs its normal (leaks.h pushes points through that face): complete just those.
  const scene::Hit hit = tracer_.complete(ray, *id);
  return HitInfo{hit.t, false, hit.ng};
}

void match_tracer_offsets(LightmapTexels& texels, const scene::Tracer& tracer) {
  for (TexelSample& s : texels.samples) {
    const int instance = static_cast<int>(s.triangle.instance);
    if (!tracer.instanced(instance)) continue;
    const double offset = tracer.ray_offset(instance, static_cast<int>(s.triangle.triangle));
    float f = static_cast<float>(offset);
    if (static_cast<double>(f) < offset) f = std::nextafter(f, INFINITY);  // never below the bound
    s.ray_offset = std::max(s.ray_offset, f);
  }
}

}  // namespace kiln::lightmap
