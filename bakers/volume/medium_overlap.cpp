#include "bakers/volume/medium_overlap.h"

#include "bakers/bake/number_format.h"

namespace kiln::volume {

namespace {

std::string point_text(const Vec3& p) {
  return "(" + bake::format_number(p.x) + ", " + bake::format_number(p.y) + ", " + bake::format_number(p.z) + ")";
}

std::string box_text(const Bounds3& b) { return "[" + point_text(b.lo) + ", " + point_text(b.hi) + "]"; }

}  // namespace

std::optional<std::string> outside_scene(const Medium& medium, const Bounds3& scene_bounds) {
  const Bounds3 b = medium.bounds();
  if (b.empty()) return "it holds no density anywhere; it affects nothing and is skipped";
  if (b.overlaps(scene_bounds)) return std::nullopt;
  return "its bounds " + box_text(b) + " do not overlap the scene's " + box_text(scene_bounds) +
         "; it affects nothing and is skipped";
}

}  // namespace kiln::volume
