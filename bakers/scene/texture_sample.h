// Reading a scene texture (scene.h: Texture) at a texture UV: bilinear, wrapping around (glTF's REPEAT, the default
// sampler), texel centres at ((i + ½)/width, (j + ½)/height), v = 0 the top row.
#pragma once

#include "bakers/math/rgb.h"
#include "bakers/math/sampling.h"
#include "bakers/scene/scene.h"

namespace kiln::scene {

// Never NaN: a non-finite UV reads texel (0, 0). An empty or malformed texture (check_scene drops references to
// those) reads 1, the neutral tint.
Rgb sample_bilinear(const Texture& texture, Point2 uv);

}  // namespace kiln::scene
