// A float grid read from (or made for) an OpenVDB file, as an opaque handle: OpenVDB's headers stay in
// bakers/volume/*.cpp (vdb_grid_impl.h), so including this costs nothing. Immutable once made; copies share it.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "bakers/math/vec3.h"

namespace kiln::volume {

class VdbGrid {
 public:
  struct Impl;

  VdbGrid() = default;
  explicit VdbGrid(std::shared_ptr<const Impl> impl) : impl_(std::move(impl)) {}

  bool valid() const { return impl_ != nullptr; }
  const std::string& name() const;
  int64_t active_voxel_count() const;
  // The index-space box [lo, hi] (inclusive voxel coordinates) holding every stored voxel and tile; lo > hi when the
  // grid holds nothing.
  std::array<int, 3> index_lo() const;
  std::array<int, 3> index_hi() const;
  // The grid's own transform from index space (voxel centres at integer coordinates) to its world space.
  Vec3 index_to_world(const Vec3& index) const;
  Vec3 voxel_size() const;
  // Voxels whose value was replaced by 0 when read (vdb_file.h): NaN or ±infinity, and negative densities.
  int64_t replaced_non_finite() const;
  int64_t replaced_negative() const;
  // The value at integer index coordinates (0 outside the stored voxels and tiles).
  float value(int i, int j, int k) const;

  const Impl& impl() const { return *impl_; }

 private:
  std::shared_ptr<const Impl> impl_;
};

// A grid named `name` of nx × ny × nz voxels from `values` (x fastest), voxel (0, 0, 0) at index `origin`, with a
// uniform voxel size and the world position of index (0, 0, 0) at `offset`. Zero values are left unstored. For tests,
// benchmarks and written outputs. Throws std::invalid_argument if values.size() ≠ nx·ny·nz or voxel_size ≤ 0.
VdbGrid make_vdb_grid(const std::string& name, int nx, int ny, int nz, const std::vector<float>& values,
                      double voxel_size, const Vec3& offset = {}, std::array<int, 3> origin = {0, 0, 0});

}  // namespace kiln::volume
