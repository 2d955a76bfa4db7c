#include "bakers/volume/vdb_grid.h"

#include <cmath>
#include <mutex>
#include <stdexcept>

#include "bakers/volume/vdb_grid_impl.h"

namespace kiln::volume {

void initialize_openvdb() {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
}

namespace {

// Replaces the values a density cannot have by 0, counting them in `impl`.
void sanitize(openvdb::FloatGrid& grid, VdbGrid::Impl& impl) {
  for (auto it = grid.tree().beginValueAll(); it; ++it) {
    const float v = *it;
    if (!std::isfinite(v)) {
      it.setValue(0.0f);
      ++impl.replaced_non_finite;
    } else if (v < 0) {
      it.setValue(0.0f);
      ++impl.replaced_negative;
    } else if (v != 0 && !it.isVoxelValue() && !it.isValueOn()) {
      it.setValue(0.0f);
    }
  }
}

}  // namespace

std::shared_ptr<const VdbGrid::Impl> adopt_float_grid(openvdb::FloatGrid::Ptr grid) {
  auto impl = std::make_shared<VdbGrid::Impl>();
  sanitize(*grid, *impl);
  openvdb::CoordBBox leaves;
  grid->tree().evalLeafBoundingBox(leaves);
  impl->stored = grid->evalActiveVoxelBoundingBox();
  if (!leaves.empty()) impl->stored.expand(leaves);
  impl->name = grid->getName();
  impl->grid = std::move(grid);
  return impl;
}

const std::string& VdbGrid::name() const { return impl_->name; }
int64_t VdbGrid::active_voxel_count() const { return static_cast<int64_t>(impl_->grid->activeVoxelCount()); }
int64_t VdbGrid::replaced_non_finite() const { return impl_->replaced_non_finite; }
int64_t VdbGrid::replaced_negative() const { return impl_->replaced_negative; }

std::array<int, 3> VdbGrid::index_lo() const {
  const openvdb::Coord c = impl_->stored.min();
  return {c.x(), c.y(), c.z()};
}

std::array<int, 3> VdbGrid::index_hi() const {
  const openvdb::Coord c = impl_->stored.max();
  return {c.x(), c.y(), c.z()};
}

Vec3 VdbGrid::index_to_world(const Vec3& index) const {
  const openvdb::Vec3d w = impl_->grid->transform().indexToWorld(openvdb::Vec3d(index.x, index.y, index.z));
  return {w.x(), w.y(), w.z()};
}

Vec3 VdbGrid::voxel_size() const {
  const openvdb::Vec3d s = impl_->grid->transform().voxelSize();
  return {s.x(), s.y(), s.z()};
}

float VdbGrid::value(int i, int j, int k) const { return impl_->grid->tree().getValue(openvdb::Coord(i, j, k)); }

VdbGrid make_vdb_grid(const std::string& name, int nx, int ny, int nz, const std::vector<float>& values,
                      double voxel_size, const Vec3& offset, std::array<int, 3> origin) {
  if (nx < 0 || ny < 0 || nz < 0 || values.size() != static_cast<size_t>(nx) * ny * nz || !(voxel_size > 0))
    throw std::invalid_argument("make_vdb_grid: values must hold nx·ny·nz voxels and voxel_size must be > 0");
  initialize_openvdb();
  auto grid = openvdb::FloatGrid::create(0.0f);
  grid->setName(name);
  grid->setTransform(openvdb::math::Transform::createLinearTransform(voxel_size));
  grid->transform().postTranslate(openvdb::Vec3d(offset.x, offset.y, offset.z));
  auto acc = grid->getAccessor();
  size_t n = 0;
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i, ++n)
        if (values[n] != 0.0f) acc.setValue(openvdb::Coord(origin[0] + i, origin[1] + j, origin[2] + k), values[n]);
  return VdbGrid(adopt_float_grid(grid));
}

}  // namespace kiln::volume
