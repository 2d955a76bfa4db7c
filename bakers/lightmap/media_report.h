// report.json's "media": what the planner decided for the bake's participating media and from what (the mode, what
// the media take from typical light paths and their albedo), and per medium its kind, whether it was simulated or
// why it was skipped, and the voxels read as 0 from its VDB grids (NaN, infinite, negative).
#pragma once

#include <string>
#include <vector>

#include "bakers/plan/lightmap_plan.h"
#include "bakers/volume/medium_input.h"

namespace kiln::lightmap {

// The JSON text of the "media" object.
std::string media_report_json(const plan::LightmapPlan& plan, const std::vector<volume::MediumInput>& media);

}  // namespace kiln::lightmap
