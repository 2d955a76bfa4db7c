// The bounds of a medium's inputs, checked by each medium's constructor and by read_vdb: the protocol's own
// (proto/bounds.h, where the client and the translation layer read them too), under the names the volume code uses.
#pragma once

#include <cstdint>

#include "proto/bounds.h"

namespace kiln::volume::limits {

using bounds::kMediumAsymmetry;
using bounds::kMediumCoefficient;
using bounds::kMediumEmission;
using bounds::kVdbActiveVoxels;
using bounds::kVdbBytes;
using bounds::kVdbExtentVoxels;
using bounds::kVdbVoxelSize;

}  // namespace kiln::volume::limits
