// The generated level (level_scene.h) packed into atlas pages as level_bench's --texel-density packs it: every
// instance's own lightmap name and placement dropped, padding 2.
#pragma once

#include <utility>

#include "bakers/lightmap/atlas_pack.h"
#include "bakers/scene/scene_check.h"
#include "tests/bench/level_scene.h"

namespace kiln::bench {

inline scene::CheckedScene packed_level(double texel_density, int page_size, lightmap::AtlasPack& pack) {
  scene::Scene level = level_scene({});
  for (scene::Instance& i : level.instances) {
    i.lightmap.clear();
    i.lightmap_scale_offset = {1, 1, 0, 0};
  }
  lightmap::AtlasOptions atlas;
  atlas.texel_density = texel_density;
  atlas.page_size = page_size;
  atlas.padding = 2;
  return lightmap::check_and_pack_scene(std::move(level), atlas, {}, pack);
}

}  // namespace kiln::bench
