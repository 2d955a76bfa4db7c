// Whether a medium can affect a scene at all: a medium whose bounds miss the scene's is reported and skipped, not
// simulated (a VDB placed by a wrong transform, a fog box in the wrong units).
#pragma once

#include <optional>
#include <string>

#include "bakers/volume/medium.h"

namespace kiln::volume {

// Nothing if the medium's bounds overlap scene_bounds; else the report, naming both boxes ("its bounds [(…), (…)]
// do not overlap the scene's [(…), (…)]; it affects nothing and is skipped"). An empty medium (a grid with no stored
// voxel) is reported too.
std::optional<std::string> outside_scene(const Medium& medium, const Bounds3& scene_bounds);

}  // namespace kiln::volume
