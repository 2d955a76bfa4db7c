#include "bakers/volume/probe_vdb.h"

#include <sstream>
#include <stdexcept>

#include <openvdb/io/Stream.h>

#include "bakers/volume/vdb_grid_impl.h"

namespace kiln::volume {
namespace {

openvdb::math::Transform::Ptr lattice_transform(const ProbeLattice& lattice) {
  auto transform = openvdb::math::Transform::createLinearTransform(lattice.voxel_size);
  transform->postTranslate(openvdb::Vec3d(lattice.origin.x, lattice.origin.y, lattice.origin.z));
  return transform;
}

void insert_strings(openvdb::MetaMap& into, const std::map<std::string, std::string>& metadata) {
  for (const auto& [key, value] : metadata) into.insertMeta(key, openvdb::StringMetadata(value));
}

std::map<std::string, std::string> strings_of(const openvdb::MetaMap& meta) {
  std::map<std::string, std::string> out;
  for (auto it = meta.beginMeta(); it != meta.endMeta(); ++it) {
    if (it->second && it->second->typeName() == openvdb::StringMetadata::staticTypeName())
      out[it->first] = it->second->str();
  }
  return out;
}

}  // namespace

std::vector<uint8_t> write_probe_vdb(const ProbeLattice& lattice, const std::vector<ProbeGridValues>& grids,
                                     const std::map<std::string, std::string>& file_metadata) {
  if (!(lattice.voxel_size > 0)) throw std::invalid_argument("write_probe_vdb: voxel_size must be > 0");
  initialize_openvdb();
  const auto transform = lattice_transform(lattice);
  openvdb::GridCPtrVec list;
  for (const ProbeGridValues& g : grids) {
    if (g.values.size() != lattice.voxels.size())
      throw std::invalid_argument("write_probe_vdb: grid " + g.name + " holds a value per probe");
    auto grid = openvdb::FloatGrid::create(0.0f);
    grid->setName(g.name);
    grid->setTransform(transform->copy());
    insert_strings(*grid, g.metadata);
    auto acc = grid->getAccessor();
    for (size_t p = 0; p < lattice.voxels.size(); ++p) {
      const auto& v = lattice.voxels[p];
      acc.setValueOn(openvdb::Coord(v[0], v[1], v[2]), g.values[p]);  // on even when 0: active voxels are the probes
    }
    list.push_back(grid);
  }
  openvdb::MetaMap meta;
  insert_strings(meta, file_metadata);
  std::ostringstream out;
  openvdb::io::Stream(out).write(list, meta);
  const std::string s = out.str();
  return {s.begin(), s.end()};
}

ProbeVdbContents read_probe_vdb(std::span<const uint8_t> bytes) {
  initialize_openvdb();
  std::istringstream in(std::string(bytes.begin(), bytes.end()));
  openvdb::GridPtrVecPtr grids;
  openvdb::MetaMap::Ptr meta;
  try {
    openvdb::io::Stream stream(in, /*delayLoad=*/false);
    grids = stream.getGrids();
    meta = stream.getMetadata();
  } catch (const std::exception& e) {
    throw std::invalid_argument(std::string("read_probe_vdb: OpenVDB could not read it: ") + e.what());
  }
  ProbeVdbContents c;
  if (meta) c.metadata = strings_of(*meta);
  for (const openvdb::GridBase::Ptr& base : *grids) {
    const auto grid = openvdb::gridPtrCast<openvdb::FloatGrid>(base);
    if (!grid) continue;
    if (c.grids.empty()) {
      const openvdb::Vec3d o = grid->transform().indexToWorld(openvdb::Vec3d(0, 0, 0));
      c.lattice.origin = {o.x(), o.y(), o.z()};
      c.lattice.voxel_size = grid->transform().voxelSize()[0];
      for (auto it = grid->cbeginValueOn(); it; ++it) {
        const openvdb::Coord q = it.getCoord();
        c.lattice.voxels.push_back({q.x(), q.y(), q.z()});
      }
    }
    ProbeGridValues g{grid->getName(), {}, strings_of(*grid)};
    const auto acc = grid->getConstAccessor();
    for (const auto& v : c.lattice.voxels) g.values.push_back(acc.getValue(openvdb::Coord(v[0], v[1], v[2])));
    c.grids.push_back(std::move(g));
  }
  if (c.grids.empty()) throw std::invalid_argument("read_probe_vdb: the file holds no float grid");
  return c;
}

}  // namespace kiln::volume
