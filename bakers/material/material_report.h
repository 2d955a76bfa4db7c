// report.json of the material bake: everything in MaterialBakeResult but the tables, for people and pipelines.
#pragma once

#include <cstddef>

#include "bakers/bake/output.h"
#include "bakers/material/material_bake.h"

namespace kiln::material {

// The report of a finished bake whose tables had `entries` entries; result.outputs lists the files before it.
bake::BakeOutput material_report(const MaterialBakeInput& input, const MaterialBakeResult& result, size_t entries);

}  // namespace kiln::material
