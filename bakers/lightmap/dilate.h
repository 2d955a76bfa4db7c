// Padding for lightmaps: valid texels grow into the invalid ones around them, so that bilinear filtering (and mip
// mapping) at a chart's edge blends with the chart's own values instead of black.
#pragma once

#include <cstdint>
#include <vector>

#include "bakers/bake/stop.h"
#include "bakers/image/exr.h"

namespace kiln::lightmap {

// Fills the invalid texels within `padding` texels (Chebyshev distance) of a valid one, ring by ring: ring r is the
// invalid texels with a texel of ring r − 1 (ring 0: the valid ones) among their 8 neighbours, and each takes the
// average of those neighbours of rings < r (every channel). Texels of the same ring do not feed each other, so the
// result does not depend on the order of the sweep. Texels farther away, and the valid ones, are left as they are.
// `valid` has width·height entries (non-zero: valid), row-major like the image; it is not changed (the validity map
// is the one from before dilation). padding ≤ 0 changes nothing. Returns the number of texels filled.
// Throws std::invalid_argument when `valid` does not match the image's size. Polls `stop` every few rows and throws
// what its check() throws (the image is then partly dilated).
size_t dilate(image::FloatImage& image, const std::vector<uint8_t>& valid, int padding,
              const bake::StopCheck& stop = {});

}  // namespace kiln::lightmap
