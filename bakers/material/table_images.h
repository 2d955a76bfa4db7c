// The material bake's tables as EXR images (albedo.exr, split_sum.exr; layout in material_bake.h), each carrying its
// layout, the model and the bake settings in string attributes (kiln:*).
#pragma once

#include <string>

#include "bakers/bake/output.h"
#include "bakers/material/material_bake.h"

namespace kiln::material {

// The kiln:settings attribute of both images.
std::string table_settings(const MaterialBakeInput& input);

bake::BakeOutput albedo_image(const MaterialBakeResult& result, const std::string& settings);
// rough_axis: the model has a roughness parameter (otherwise every row is the same).
bake::BakeOutput split_sum_image(const MaterialBakeResult& result, brdf::Model model, bool rough_axis,
                                 const std::string& settings);

}  // namespace kiln::material
