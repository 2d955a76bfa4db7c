// report.json of an environment bake: the settings, every level (size, roughness, samples, estimated errors, time),
// the sample and time totals, the plan, the sun split, the conventions, the colour space, the memory estimate and the
// sanitised texel counts.
#pragma once

#include <string>

#include "bakers/envmap/environment_bake.h"

namespace kiln::envmap {

// The report of `result` (its levels, plan, samples and times filled in) baked from `input` in `color_space`, as
// JSON text ending in a newline. A non-finite number is written as null.
std::string environment_report_json(const EnvironmentBakeInput& input, const EnvironmentBakeResult& result,
                                    const std::string& color_space);

}  // namespace kiln::envmap
