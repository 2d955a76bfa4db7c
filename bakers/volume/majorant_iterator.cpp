#include "bakers/volume/majorant_iterator.h"

#include <algorithm>
#include <cmath>

#include "bakers/volume/ray_box.h"

namespace kiln::volume {

MajorantIterator MajorantIterator::single(double t_min, double t_max, const Rgb& sigma_maj) {
  MajorantIterator it;
  it.t_min_ = t_min;
  it.t_max_ = std::max(t_min, t_max);
  it.sigma_ = sigma_maj;
  return it;
}

MajorantIterator MajorantIterator::dda(const MajorantGrid& grid, const Vec3& origin, const Vec3& direction,
                                       double t_min, double t_max, const Rgb& sigma_t_per_density) {
  MajorantIterator it;
  const int n[3] = {grid.nx(), grid.ny(), grid.nz()};
  if (!clip_ray_to_box(origin, direction, {0, 0, 0}, Vec3(n[0], n[1], n[2]), t_min, t_max))
    return it;  // misses the grid: yields nothing
  it.grid_ = &grid;
  it.t_min_ = t_min;
  it.t_max_ = t_max;
  it.sigma_ = sigma_t_per_density;
  const Vec3 p = origin + direction * t_min;
  for (int a = 0; a < 3; ++a) it.start_axis(a, axis(p, a), axis(direction, a), n[a]);
  return it;
}

void MajorantIterator::start_axis(int a, double p, double d, int n) {
  cell_[a] = std::clamp(static_cast<int>(std::floor(p)), 0, n - 1);
  // A ray parallel to this axis never crosses a cell boundary along it.
  if (d == 0.0) {
    next_crossing_[a] = INFINITY;
    exit_[a] = -1;  // the cell index never changes, so never reaches -1
    return;
  }
  const bool up = d > 0;
  next_crossing_[a] = t_min_ + (cell_[a] + (up ? 1 : 0) - p) / d;
  delta_t_[a] = std::fabs(1.0 / d);
  step_[a] = up ? 1 : -1;
  exit_[a] = up ? n : -1;
}

std::optional<MajorantSegment> MajorantIterator::next() { return grid_ ? next_cell() : next_single(); }

std::optional<MajorantSegment> MajorantIterator::next_single() {
  if (!(t_min_ < t_max_)) return std::nullopt;
  const MajorantSegment s{t_min_, t_max_, sigma_};
  t_min_ = t_max_;
  return s;
}

std::optional<MajorantSegment> MajorantIterator::next_cell() {
  if (!(t_min_ < t_max_)) return std::nullopt;
  int a = 0;  // the axis whose boundary the ray crosses first
  if (next_crossing_[1] < next_crossing_[a]) a = 1;
  if (next_crossing_[2] < next_crossing_[a]) a = 2;
  const double t_exit = std::min(t_max_, next_crossing_[a]);
  const MajorantSegment s{t_min_, t_exit, sigma_ * grid_->max(cell_[0], cell_[1], cell_[2])};
  t_min_ = t_exit;
  cell_[a] += step_[a];
  next_crossing_[a] += delta_t_[a];
  // Leaving the grid ends the walk (rounding could otherwise step one cell past the clipped interval).
  if (cell_[a] == exit_[a]) t_min_ = t_max_;
  return s;
}

}  // namespace kiln::volume
