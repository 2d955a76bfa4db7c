#include "bakers/volume/majorant_grid.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace kiln::volume {

MajorantGrid::MajorantGrid(const Vec3& lo, double cell, int nx, int ny, int nz)
    : lo_(lo), cell_(cell), nx_(nx), ny_(ny), nz_(nz) {
  if (!(cell > 0) || !std::isfinite(cell) || nx <= 0 || ny <= 0 || nz <= 0 || !is_finite(lo))
    throw std::invalid_argument("majorant grid: needs a positive finite cell and at least one cell per axis");
  max_.assign(static_cast<size_t>(nx) * ny * nz, 0.0f);
}

void MajorantGrid::raise(const Vec3& a, const Vec3& b, float v) {
  const Vec3 ca = to_cells(a), cb = to_cells(b);
  // Cells overlapping [a, b], clamped to the grid: a box reaching past the grid raises its border cells only.
  auto first = [](double c, int n) { return std::clamp(static_cast<int>(std::floor(c)), 0, n - 1); };
  const int i0 = first(ca.x, nx_), i1 = first(cb.x, nx_);
  const int j0 = first(ca.y, ny_), j1 = first(cb.y, ny_);
  const int k0 = first(ca.z, nz_), k1 = first(cb.z, nz_);
  for (int k = k0; k <= k1; ++k)
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) {
        float& m = max_[index(i, j, k)];
        m = std::max(m, v);
      }
}

float MajorantGrid::overall_max() const { return max_.empty() ? 0.0f : *std::max_element(max_.begin(), max_.end()); }

}  // namespace kiln::volume
