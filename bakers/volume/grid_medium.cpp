#include "bakers/volume/grid_medium.h"

#include <algorithm>
#include <cmath>

#include <openvdb/tools/Interpolation.h>

#include "bakers/bake/range_check.h"
#include "bakers/volume/affine.h"
#include "bakers/volume/medium_bounds.h"
#include "bakers/volume/vdb_grid_impl.h"

namespace kiln::volume {

namespace {

using bake::InvalidInput;

void validate(const GridMediumSpec& s) {
  if (auto e = bake::check_rgb("sigma_a", s.sigma_a, limits::kMediumCoefficient)) throw *e;
  if (auto e = bake::check_rgb("sigma_s", s.sigma_s, limits::kMediumCoefficient)) throw *e;
  if (auto e = bake::check_rgb("Le_scale", s.Le_scale, limits::kMediumEmission)) throw *e;
  if (auto e = bake::check_range("g", s.g, limits::kMediumAsymmetry)) throw *e;
  if (!s.density.valid()) throw InvalidInput("density", "no grid given");
  if (s.emission && !s.emission->valid()) throw InvalidInput("emission", "an empty grid handle");
}

// World ← medium ← index: the grid's own (linear) transform, then the medium's placement.
scene::Transform world_from_index(const VdbGrid& grid, const scene::Transform& to_world) {
  const Vec3 o = grid.index_to_world({0, 0, 0});
  const scene::Transform medium_from_index = from_columns(
      grid.index_to_world({1, 0, 0}) - o, grid.index_to_world({0, 1, 0}) - o, grid.index_to_world({0, 0, 1}) - o, o);
  return compose(to_world, medium_from_index);
}

scene::Transform inverted(const scene::Transform& t, const std::string& field) {
  const auto inv = inverse(t);
  if (!inv) throw InvalidInput(field, "is singular or not finite (composed with the grid's own transform)");
  return *inv;
}

// The shortest world-space voxel edge.
double min_voxel_edge(const scene::Transform& world_from_index) {
  return std::min({length(world_from_index.vector({1, 0, 0})), length(world_from_index.vector({0, 1, 0})),
                   length(world_from_index.vector({0, 0, 1}))});
}

double grid_max(const openvdb::FloatGrid& grid) {
  float m = 0;
  for (auto it = grid.tree().cbeginValueAll(); it; ++it) m = std::max(m, *it);
  return m;
}

// Above the cap a voxel's length has optical depth ≥ kOpaqueVoxelDepth in its densest channel.
double cap_for(const GridMediumSpec& s, const scene::Transform& world_from_index) {
  const double largest = grid_max(*s.density.impl().grid);
  const double sigma_t = (s.sigma_a + s.sigma_s).max();
  // A medium with no coefficient collides nowhere: nothing to cap.
  if (sigma_t == 0) return largest;
  return std::min(largest, GridMedium::kOpaqueVoxelDepth / (sigma_t * min_voxel_edge(world_from_index)));
}

}  // namespace

namespace {

// Cells of `edge` voxels covering index coordinates [lo, hi] on one axis, aligned to multiples of edge.
int64_t cells_on_axis(int64_t lo, int64_t hi, int64_t edge) {
  return static_cast<int64_t>(std::floor(double(hi) / edge) - std::floor(double(lo) / edge)) + 1;
}

// The cell edge (in voxels) of the majorant grid over the index box [lo, hi]: a leaf node's 8 voxels, doubled until
// the grid fits kMaxMajorantCells (a wide, sparse grid gets coarser cells, never more memory).
int64_t majorant_edge(const std::array<int64_t, 3>& lo, const std::array<int64_t, 3>& hi) {
  int64_t edge = openvdb::FloatTree::LeafNodeType::DIM;
  auto count = [&](int a) { return static_cast<size_t>(cells_on_axis(lo[a], hi[a], edge)); };
  while (count(0) * count(1) * count(2) > GridMedium::kMaxMajorantCells) edge *= 2;
  return edge;
}

// The majorant grid's empty shape over the index box [lo, hi].
MajorantGrid majorant_shape(const openvdb::Coord& lo, const openvdb::Coord& hi) {
  const std::array<int64_t, 3> a{lo.x(), lo.y(), lo.z()}, b{hi.x(), hi.y(), hi.z()};
  const int64_t edge = majorant_edge(a, b);
  auto count = [&](int k) { return static_cast<int>(cells_on_axis(a[k], b[k], edge)); };
  const Vec3 origin(std::floor(double(lo[0]) / edge) * edge, std::floor(double(lo[1]) / edge) * edge,
                    std::floor(double(lo[2]) / edge) * edge);
  return MajorantGrid(origin, static_cast<double>(edge), count(0), count(1), count(2));
}

Vec3 vec(const openvdb::Coord& c) { return {double(c.x()), double(c.y()), double(c.z())}; }

// Each leaf's and tile's largest value raises the cells its trilinear reach overlaps: a voxel v affects lookups in
// (v − 1, v + 1) on each axis. Values are capped first.
MajorantGrid build_majorant(const VdbGrid::Impl& impl, double cap) {
  // An empty grid: one cell of 0 (the medium is nowhere).
  if (impl.stored.empty()) return MajorantGrid({0, 0, 0}, 8, 1, 1, 1);
  const openvdb::Coord reach(1, 1, 1);
  MajorantGrid m = majorant_shape(impl.stored.min() - reach, impl.stored.max() + reach);
  const openvdb::FloatTree& tree = impl.grid->tree();
  for (auto leaf = tree.cbeginLeaf(); leaf; ++leaf) {
    const float* v = leaf->buffer().data();
    const float largest = *std::max_element(v, v + leaf->size());
    const openvdb::Coord o = leaf->origin();
    m.raise(vec(o - reach), vec(o + openvdb::Coord(leaf->dim())), static_cast<float>(std::min<double>(largest, cap)));
  }
  auto tile = tree.cbeginValueAll();
  tile.setMaxDepth(tile.getLeafDepth() - 1);  // tiles only: the leaves' voxels are done above
  for (; tile; ++tile) {
    if (*tile == 0) continue;
    openvdb::CoordBBox box;
    tile.getBoundingBox(box);
    m.raise(vec(box.min() - reach), vec(box.max() + reach), static_cast<float>(std::min<double>(*tile, cap)));
  }
  return m;
}

// The world-space box of the majorant grid's cells.
Bounds3 world_bounds(const MajorantGrid& m, const scene::Transform& world_from_index) {
  Bounds3 b;
  const Vec3 hi = m.lo() + Vec3(m.nx(), m.ny(), m.nz()) * m.cell();
  for (int c = 0; c < 8; ++c) {
    const Vec3 p = world_from_index.point({c & 1 ? hi.x : m.lo().x, c & 2 ? hi.y : m.lo().y, c & 4 ? hi.z : m.lo().z});
    b.lo = {std::min(b.lo.x, p.x), std::min(b.lo.y, p.y), std::min(b.lo.z, p.z)};
    b.hi = {std::max(b.hi.x, p.x), std::max(b.hi.y, p.y), std::max(b.hi.z, p.z)};
  }
  return b;
}

float sample(const openvdb::FloatGrid& grid, const Vec3& index) {
  const auto acc = grid.getConstUnsafeAccessor();
  return openvdb::tools::BoxSampler::sample(acc, openvdb::Vec3R(index.x, index.y, index.z));
}

}  // namespace

GridMedium::GridMedium(const GridMediumSpec& spec) : spec_(spec) {
  validate(spec_);
  const scene::Transform world_from_density = world_from_index(spec_.density, spec_.to_world);
  index_from_world_ = inverted(world_from_density, "to_world");
  if (spec_.emission)
    emission_index_from_world_ = inverted(world_from_index(*spec_.emission, spec_.to_world), "to_world");
  density_cap_ = cap_for(spec_, world_from_density);
  majorant_ = build_majorant(spec_.density.impl(), density_cap_);
  if (!spec_.density.impl().stored.empty()) bounds_ = world_bounds(majorant_, world_from_density);
}

GridMedium::~GridMedium() = default;

size_t GridMedium::majorant_cells(const std::array<int64_t, 3>& stored_lo, const std::array<int64_t, 3>& stored_hi) {
  if (stored_lo[0] > stored_hi[0] || stored_lo[1] > stored_hi[1] || stored_lo[2] > stored_hi[2]) return 1;
  // build_majorant's reach: one voxel either side.
  const std::array<int64_t, 3> lo{stored_lo[0] - 1, stored_lo[1] - 1, stored_lo[2] - 1};
  const std::array<int64_t, 3> hi{stored_hi[0] + 1, stored_hi[1] + 1, stored_hi[2] + 1};
  const int64_t edge = majorant_edge(lo, hi);
  size_t cells = 1;
  for (int a = 0; a < 3; ++a) cells *= static_cast<size_t>(cells_on_axis(lo[a], hi[a], edge));
  return cells;
}

double GridMedium::density(const Vec3& p) const {
  return std::min<double>(sample(*spec_.density.impl().grid, index_from_world_.point(p)), density_cap_);
}

MediumProperties GridMedium::at(const Vec3& p) const {
  const double d = density(p);
  MediumProperties mp{spec_.sigma_a * d, spec_.sigma_s * d, {}};
  if (emission_index_from_world_)
    mp.Le = spec_.Le_scale * sample(*spec_.emission->impl().grid, emission_index_from_world_->point(p));
  return mp;
}

MajorantIterator GridMedium::majorants(const scene::Ray& ray, double t_end) const {
  const Vec3 o = majorant_.to_cells(index_from_world_.point(ray.origin));
  const Vec3 d = majorant_.vector_to_cells(index_from_world_.vector(ray.direction));
  return MajorantIterator::dda(majorant_, o, d, 0, t_end, spec_.sigma_a + spec_.sigma_s);
}

}  // namespace kiln::volume
