#include "bakers/volume/vdb_file.h"

#include <cmath>
#include <cstring>
#include <istream>
#include <map>
#include <sstream>
#include <streambuf>

#include <openvdb/io/Stream.h>

#include "bakers/bake/invalid_input.h"
#include "bakers/bake/number_format.h"
#include "bakers/volume/medium_bounds.h"
#include "bakers/volume/vdb_grid_impl.h"
#include "bakers/volume/vdb_structure.h"

namespace kiln::volume {

namespace {

using bake::format_number;
using bake::InvalidInput;

// A read-only stream over the blob's bytes, so OpenVDB parses them without a copy.
class SpanBuffer : public std::streambuf {
 public:
  explicit SpanBuffer(std::span<const uint8_t> bytes) {
    char* begin = const_cast<char*>(reinterpret_cast<const char*>(bytes.data()));
    setg(begin, begin, begin + bytes.size());
  }

 protected:
  pos_type seekoff(off_type off, std::ios_base::seekdir dir, std::ios_base::openmode) override {
    const off_type base =
        dir == std::ios_base::beg ? 0 : (dir == std::ios_base::cur ? gptr() - eback() : egptr() - eback());
    return seekpos(pos_type(base + off), std::ios_base::in);
  }
  pos_type seekpos(pos_type pos, std::ios_base::openmode) override {
    if (pos < 0 || pos > egptr() - eback()) return pos_type(off_type(-1));
    setg(eback(), eback() + pos, egptr());
    return pos;
  }
};

void check_header(std::span<const uint8_t> bytes) {
  const int64_t n = static_cast<int64_t>(bytes.size());
  if (!limits::kVdbBytes.contains(n))
    throw InvalidInput("bytes", "a VDB file must hold 1 to " + std::to_string(limits::kVdbBytes.hi) + " bytes, got " +
                                    std::to_string(n));
  // OpenVDB files open with the 64-bit magic number OPENVDB_MAGIC ("VDB " little-endian).
  int64_t magic = 0;
  if (bytes.size() >= sizeof magic) std::memcpy(&magic, bytes.data(), sizeof magic);
  if (magic != openvdb::OPENVDB_MAGIC)
    throw InvalidInput("bytes", "is not an OpenVDB file (it does not start with OpenVDB's magic number)");
}

openvdb::GridPtrVecPtr parse(std::span<const uint8_t> bytes) {
  initialize_openvdb();
  SpanBuffer buffer(bytes);
  std::istream in(&buffer);
  try {
    openvdb::io::Stream stream(in, /*delayLoad=*/false);
    return stream.getGrids();
  } catch (const std::exception& e) {
    // What the structure walk leaves to OpenVDB: a compressed chunk whose data does not decompress, a transform
    // OpenVDB cannot invert. Thrown while reading leaf buffers or transforms, where nothing leaks.
    throw InvalidInput("bytes", std::string("OpenVDB could not read it: ") + e.what());
  }
}

void check_transform(const openvdb::GridBase& grid, const std::string& field) {
  if (!grid.transform().isLinear())
    throw InvalidInput(field, "has a non-linear (frustum) transform; kiln reads grids with linear transforms");
  const openvdb::Vec3d size = grid.transform().voxelSize();
  for (int a = 0; a < 3; ++a)
    if (!std::isfinite(size[a]) || !limits::kVdbVoxelSize.contains(size[a]))
      throw InvalidInput(field, "voxel edges must be in (0, " + format_number(limits::kVdbVoxelSize.hi) + "], got " +
                                    format_number(size[0]) + " × " + format_number(size[1]) + " × " +
                                    format_number(size[2]));
}

void check_sizes(const openvdb::FloatGrid& grid, const std::string& field) {
  const int64_t cap = limits::kVdbActiveVoxels.hi;
  const int64_t active = static_cast<int64_t>(grid.activeVoxelCount());
  const int64_t stored = static_cast<int64_t>(grid.tree().leafCount()) * 512;
  if (active > cap || stored > cap)
    throw InvalidInput(field, "holds " + std::to_string(active) + " active and " + std::to_string(stored) +
                                  " stored voxels; at most " + std::to_string(cap) + " of each are allowed");
  openvdb::CoordBBox box = grid.evalActiveVoxelBoundingBox();
  openvdb::CoordBBox leaves;
  if (grid.tree().evalLeafBoundingBox(leaves)) box.expand(leaves);
  if (box.empty()) return;
  const openvdb::Coord extent = box.dim();
  for (int a = 0; a < 3; ++a)
    if (extent[a] > limits::kVdbExtentVoxels.hi)
      throw InvalidInput(field, "spans " + std::to_string(extent[0]) + " × " + std::to_string(extent[1]) + " × " +
                                    std::to_string(extent[2]) + " voxels; at most " +
                                    std::to_string(limits::kVdbExtentVoxels.hi) + " on each axis are allowed");
}

// The named grid, checked (read_vdb's rules) before anything is made from it.
openvdb::FloatGrid::Ptr checked_grid(const openvdb::GridBase::Ptr& base, const std::string& field) {
  const openvdb::FloatGrid::Ptr grid = openvdb::gridPtrCast<openvdb::FloatGrid>(base);
  if (!grid) throw InvalidInput(field, "is a " + base->valueType() + " grid; kiln reads float grids");
  if (grid->background() != 0.0f)
    throw InvalidInput(field, "has background " + format_number(grid->background()) +
                                  "; a density's background (its value outside the grid) must be 0");
  check_transform(*grid, field);
  check_sizes(*grid, field);
  return grid;
}

std::string grid_list(const openvdb::GridPtrVec& grids) {
  std::string names;
  for (const auto& g : grids) names += (names.empty() ? "'" : ", '") + g->getName() + "'";
  return names.empty() ? "none" : names;
}

openvdb::GridBase::Ptr find_grid(const openvdb::GridPtrVec& grids, const std::string& name) {
  openvdb::GridBase::Ptr found;
  for (const auto& g : grids) {
    if (g->getName() != name) continue;
    if (found) throw InvalidInput("grids[" + name + "]", "the file holds more than one grid of that name");
    found = g;
  }
  if (!found) throw InvalidInput("grids[" + name + "]", "no such grid; the file holds " + grid_list(grids));
  return found;
}

}  // namespace

std::vector<VdbGrid> read_vdb(std::span<const uint8_t> bytes, const std::vector<std::string>& names) {
  check_header(bytes);
  // OpenVDB trusts the sizes and counts a file declares (vdb_structure.h): it sees only files the walk accepts.
  check_vdb_structure(bytes);
  const openvdb::GridPtrVecPtr grids = parse(bytes);
  std::vector<VdbGrid> out;
  for (const std::string& name : names) {
    const std::string field = "grids[" + name + "]";
    for (const VdbGrid& g : out)
      if (g.name() == name) throw InvalidInput(field, "is named twice; name each grid once");
    out.emplace_back(adopt_float_grid(checked_grid(find_grid(*grids, name), field)));
  }
  return out;
}

std::vector<uint8_t> write_vdb(const std::vector<VdbGrid>& grids) {
  initialize_openvdb();
  openvdb::GridCPtrVec list;
  for (const VdbGrid& g : grids) list.push_back(g.impl().grid);
  std::ostringstream out;
  openvdb::io::Stream(out).write(list);
  const std::string s = out.str();
  return {s.begin(), s.end()};
}

}  // namespace kiln::volume
