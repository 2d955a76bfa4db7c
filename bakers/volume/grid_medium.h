// A heterogeneous medium from an OpenVDB density grid (pbrt-v4's GridMedium over a NanoVDB/VDB density, §11.4.3):
// sigma_a = density × sigma_a, sigma_s = density × sigma_s, with the density interpolated trilinearly between voxel
// centres, placed in the scene by a 3×4 transform; optional emission Le = emission grid × Le_scale. Its majorants
// come from the VDB tree's nodes: one cell per leaf node (8³ voxels, coarser for grids too wide for
// kMaxMajorantCells), holding the largest value of the leaf and its neighbours' border voxels (the interpolation
// reaches one voxel across), so tracking skips the space between leaves whole.
//
// Density spikes: a value is capped where a single voxel at the cap already has optical depth kOpaqueVoxelDepth
// (docs/MEDIA.md, "Stability"), so a 1e6 spike costs a bounded number of null collisions per ray.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>

#include "bakers/scene/scene.h"
#include "bakers/volume/majorant_grid.h"
#include "bakers/volume/medium.h"
#include "bakers/volume/vdb_grid.h"

namespace kiln::volume {

struct GridMediumSpec {
  VdbGrid density;                  // a float grid (vdb_file.h); its transform maps index space to medium space
  std::optional<VdbGrid> emission;  // Le = value × Le_scale, in its own index space
  scene::Transform to_world;        // medium space → scene
  Rgb sigma_a, sigma_s;             // per unit density, m⁻¹, each in limits::kMediumCoefficient
  Rgb Le_scale;                     // in limits::kMediumEmission
  double g = 0;                     // in limits::kMediumAsymmetry
};

class GridMedium final : public Medium {
 public:
  // A voxel whose length at the capped density has this optical depth transmits e^-1000 (0 in double).
  static constexpr double kOpaqueVoxelDepth = 1000;
  // The majorant grid's cell budget: 2^22 floats, 16 MiB.
  static constexpr size_t kMaxMajorantCells = size_t{1} << 22;

  // Throws bake::InvalidInput naming the field (sigma_a, sigma_s, Le_scale, g, to_world, density) on a bad value,
  // a singular transform or a missing grid.
  explicit GridMedium(const GridMediumSpec& spec);
  ~GridMedium() override;

  MediumProperties at(const Vec3& p) const override;
  MajorantIterator majorants(const scene::Ray& ray, double t_end) const override;
  double g() const override { return spec_.g; }
  Bounds3 bounds() const override { return bounds_; }

  // The cells of the majorant grid (4 bytes each) a density whose leaves and active tiles span the index box
  // [stored_lo, stored_hi] gets (VdbGridStructure's box; lo > hi for an empty grid), for memory estimates.
  static size_t majorant_cells(const std::array<int64_t, 3>& stored_lo, const std::array<int64_t, 3>& stored_hi);

  const MajorantGrid& majorant_grid() const { return majorant_; }
  // The largest density lookups return (the cap, or the grid's largest value if lower).
  double density_cap() const { return density_cap_; }
  // The density at world point p, as tracking sees it (interpolated, capped).
  double density(const Vec3& p) const;

 private:
  GridMediumSpec spec_;
  scene::Transform index_from_world_;
  std::optional<scene::Transform> emission_index_from_world_;
  double density_cap_ = 0;
  MajorantGrid majorant_;
  Bounds3 bounds_;
};

}  // namespace kiln::volume
