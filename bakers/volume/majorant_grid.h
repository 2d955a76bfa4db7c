// A coarse dense grid of upper bounds on a density (pbrt-v4's MajorantGrid, §11.4.3): each cell holds the largest
// value any lookup inside it can return, so tracking against it is unbiased, and cells over empty space hold 0, so
// tracking steps over them without a single lookup. It lives in the density's index space: cell (i, j, k) covers
// [lo + cell·(i, j, k), lo + cell·(i+1, j+1, k+1)). No OpenVDB here: grid_medium.cpp fills it from a VDB tree.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "bakers/math/vec3.h"

namespace kiln::volume {

class MajorantGrid {
 public:
  MajorantGrid() = default;
  // nx·ny·nz cells of edge `cell` (index units) from `lo`, all 0. Throws std::invalid_argument for an empty or
  // non-positive shape.
  MajorantGrid(const Vec3& lo, double cell, int nx, int ny, int nz);

  int nx() const { return nx_; }
  int ny() const { return ny_; }
  int nz() const { return nz_; }
  double cell() const { return cell_; }
  const Vec3& lo() const { return lo_; }
  size_t cell_count() const { return max_.size(); }

  float max(int i, int j, int k) const { return max_[index(i, j, k)]; }
  // Raises every cell overlapping the index-space box [a, b] to at least v.
  void raise(const Vec3& a, const Vec3& b, float v);
  // A point of index space in the grid's cell coordinates (cell (i, j, k) is [i, i+1) × [j, j+1) × [k, k+1)).
  Vec3 to_cells(const Vec3& p) const { return (p - lo_) / cell_; }
  Vec3 vector_to_cells(const Vec3& v) const { return v / cell_; }
  // The largest value in the grid.
  float overall_max() const;

 private:
  size_t index(int i, int j, int k) const { return (static_cast<size_t>(k) * ny_ + j) * nx_ + i; }

  Vec3 lo_;
  double cell_ = 1;
  int nx_ = 0, ny_ = 0, nz_ = 0;
  std::vector<float> max_;
};

}  // namespace kiln::volume
