// The bounds of a medium's inputs, checked by each medium's constructor and by read_vdb. The protocol does not carry
// media yet (docs/MEDIA.md, "Not yet wired"); when LightmapJob does, these are its bounds and belong in
// proto/bounds.h beside the others, where the client and the translation layer read them too.
#pragma once

#include <cstdint>

#include "proto/bounds.h"

namespace kiln::volume::limits {

// sigma_a and sigma_s each channel, per metre (per scene unit); for a grid medium, per unit of density. 1e6 m⁻¹ is a
// mean free path of a micrometre: opaque at any scene scale.
inline constexpr bounds::Range kMediumCoefficient{0.0, 1e6};
// Henyey–Greenstein asymmetry g; ±1 (a Dirac delta) is accepted and narrowed by the phase function
// (henyey_greenstein.h).
inline constexpr bounds::Range kMediumAsymmetry{-1.0, 1.0};
inline constexpr bounds::Range kMediumEmission{0.0, 1e6};  // emitted radiance Le (or its scale for an emission grid)
// A VDB blob: its bytes, the active voxels of each grid read from it, the extent of a grid's active voxels in voxels
// along each axis, and the world-space size of a voxel (the grid's own transform, before the medium's).
inline constexpr bounds::WholeRange kVdbBytes{1, int64_t{256} << 20};
inline constexpr bounds::WholeRange kVdbActiveVoxels{0, int64_t{1} << 26};
inline constexpr bounds::WholeRange kVdbExtentVoxels{1, 1 << 16};
inline constexpr bounds::Range kVdbVoxelSize{0.0, 1e6, true};

}  // namespace kiln::volume::limits
