// The light probes' file (probes.vdb, docs/PROBES.md): sparse float grids over one lattice, one active voxel per
// probe, with the metadata an engine needs to read them without kiln (string metadata on the file and on every grid).
// Unlike read_vdb (the media's densities, where a negative value is not light and reads as 0), the reader here keeps
// every value as written: SH coefficients are negative as often as positive. OpenVDB stays in probe_vdb.cpp.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <span>
#include <string>
#include <vector>

#include "bakers/math/vec3.h"

namespace kiln::volume {

// Voxel (i, j, k) stands at origin + voxel_size·(i, j, k) in world space.
struct ProbeLattice {
  Vec3 origin;
  double voxel_size = 1;
  std::vector<std::array<int, 3>> voxels;  // the active voxels, one per probe, each once
};

struct ProbeGridValues {
  std::string name;
  std::vector<float> values;                    // one per lattice voxel, in the lattice's order
  std::map<std::string, std::string> metadata;  // on this grid
};

// The file's bytes: each grid with every lattice voxel active (a 0 too) and nothing else stored, background 0.
// Throws std::invalid_argument if a grid's values do not match the lattice or voxel_size is not > 0.
std::vector<uint8_t> write_probe_vdb(const ProbeLattice& lattice, const std::vector<ProbeGridValues>& grids,
                                     const std::map<std::string, std::string>& file_metadata);

struct ProbeVdbContents {
  ProbeLattice lattice;                         // from the first grid: its active voxels, its transform
  std::vector<ProbeGridValues> grids;           // every float grid, values at the lattice's voxels
  std::map<std::string, std::string> metadata;  // the file's string metadata
};

// Reads a file write_probe_vdb made (tests, tools). Throws std::invalid_argument for bytes OpenVDB cannot read or
// that hold no float grid.
ProbeVdbContents read_probe_vdb(std::span<const uint8_t> bytes);

}  // namespace kiln::volume
