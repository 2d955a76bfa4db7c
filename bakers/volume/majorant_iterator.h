// The majorants of a medium along a ray, one piecewise-constant segment at a time (pbrt-v4's
// HomogeneousMajorantIterator and DDAMajorantIterator, §11.4.3). One concrete type for both, so a medium hands it
// out by value and the tracking loop (tracking.h) pays no allocation per ray.
#pragma once

#include <optional>

#include "bakers/math/rgb.h"
#include "bakers/math/vec3.h"
#include "bakers/volume/majorant_grid.h"

namespace kiln::volume {

// sigma_maj bounds sigma_t at every point of the ray with t in [t_min, t_max).
struct MajorantSegment {
  double t_min = 0, t_max = 0;
  Rgb sigma_maj;
};

class MajorantIterator {
 public:
  // Yields nothing: a ray that misses the medium.
  MajorantIterator() = default;
  // One segment (a homogeneous medium): [t_min, t_max) with sigma_maj, nothing if the interval is empty.
  static MajorantIterator single(double t_min, double t_max, const Rgb& sigma_maj);
  // A 3D DDA (Amanatides & Woo 1987) through `grid`'s cells of the ray origin + t·direction (given in the grid's
  // cell coordinates, MajorantGrid::to_cells) over [t_min, t_max): one segment per cell crossed, with sigma_maj =
  // the cell's maximum × sigma_t_per_density. `grid` must outlive the iterator.
  static MajorantIterator dda(const MajorantGrid& grid, const Vec3& origin, const Vec3& direction, double t_min,
                              double t_max, const Rgb& sigma_t_per_density);

  std::optional<MajorantSegment> next();

 private:
  std::optional<MajorantSegment> next_single();
  std::optional<MajorantSegment> next_cell();
  // The DDA's state on axis a from the entry point's coordinate p, the direction's d and the cells n.
  void start_axis(int a, double p, double d, int n);

  const MajorantGrid* grid_ = nullptr;  // null: a single segment
  double t_min_ = 0, t_max_ = 0;
  Rgb sigma_;  // the single segment's sigma_maj, or sigma_t per unit density for the grid
  // DDA state, per axis: the current cell, the t of the next crossing, the t between crossings, the step and the
  // cell index that means "left the grid".
  int cell_[3] = {0, 0, 0};
  double next_crossing_[3] = {0, 0, 0};
  double delta_t_[3] = {0, 0, 0};
  int step_[3] = {0, 0, 0};
  int exit_[3] = {0, 0, 0};
};

}  // namespace kiln::volume
