// What a VdbGrid holds. Only bakers/volume/*.cpp include this: it pulls in OpenVDB.
#pragma once

#include <openvdb/openvdb.h>

#include "bakers/volume/vdb_grid.h"

namespace kiln::volume {

struct VdbGrid::Impl {
  openvdb::FloatGrid::Ptr grid;  // never modified once the handle is made
  std::string name;
  openvdb::CoordBBox stored;  // every leaf and active tile; inactive tiles hold 0 (vdb_file.cpp)
  int64_t replaced_non_finite = 0;
  int64_t replaced_negative = 0;
};

// openvdb::initialize(), once per process, before any grid is made, read or written.
void initialize_openvdb();

}  // namespace kiln::volume

namespace kiln::volume {

// Takes a float grid whose background is 0 into a handle: every NaN, infinite or negative value becomes 0 (counted),
// inactive tiles become 0 (OpenVDB's samplers read them, and nothing bounds them otherwise), and the stored box is
// measured.
std::shared_ptr<const VdbGrid::Impl> adopt_float_grid(openvdb::FloatGrid::Ptr grid);

}  // namespace kiln::volume
