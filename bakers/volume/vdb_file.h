// OpenVDB files in memory: the grids a medium needs read from a blob's bytes, validated, and grids written back out
// (tests, and later the probe volumes). The rules are in docs/MEDIA.md ("Validation").
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "bakers/volume/vdb_grid.h"

namespace kiln::volume {

// Reads the grids named in `names` (each once, in that order) from the bytes of a .vdb file. Checked before OpenVDB
// parses anything: the size (limits::kVdbBytes), OpenVDB's magic number, and the whole file's structure
// (check_vdb_structure: every grid's descriptor, metadata, transform, topology and compressed chunks, node counts and
// the memory OpenVDB will allocate for them). Checked on each named grid before kiln
// allocates anything for it: it exists, it is a float grid, its background is 0, its transform is linear with every
// voxel edge in limits::kVdbVoxelSize, its active voxels and its stored voxels (leaf nodes × 512) are at most
// limits::kVdbActiveVoxels, and its stored box spans at most limits::kVdbExtentVoxels on each axis. NaN, infinite
// and negative values are then replaced by 0 and counted (VdbGrid::replaced_*). Throws bake::InvalidInput with field
// "bytes" (the file as a whole) or "grids[NAME]" (one grid), saying what was found and what is allowed.
std::vector<VdbGrid> read_vdb(std::span<const uint8_t> bytes, const std::vector<std::string>& names);

// The bytes of a .vdb file holding `grids` (OpenVDB's stream format, with its default compression).
std::vector<uint8_t> write_vdb(const std::vector<VdbGrid>& grids);

}  // namespace kiln::volume
