// A VDB medium's part of the lightmap memory estimate (lightmap::vdb_medium_size, from the file's structure alone)
// against what the bake really holds for it: OpenVDB's own count of every tree the file's reading makes
// (Tree::memUsage), kiln's majorant grid (its cells, a float each) and the file's bytes, held while it is read. The
// estimate must be at least that (the daemon's admission relies on it) and at most 3 times it: the walk counts an
// internal node's table at 8 + 2 × 4 bytes an entry where OpenVDB's float tree holds 8 (NodeUnion) plus its masks,
// and a leaf at 2,304 bytes where OpenVDB holds about 2,150, so the estimate runs up to about twice the trees when
// internal nodes dominate (small grids) and near 1.1 times when leaves do; 3 leaves room for OpenVDB's allocator
// padding without letting a per-voxel or per-cell term go uncounted or doubled.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <vector>

#include "bakers/lightmap/memory_estimate.h"
#include "bakers/volume/grid_medium.h"
#include "bakers/volume/vdb_file.h"
#include "bakers/volume/vdb_grid_impl.h"

namespace kiln::volume {
namespace {

// A dense block of n × n × n voxels of density 1 from index `origin`, and optionally a second, far one.
VdbGrid block(const std::string& name, int n, std::array<int, 3> origin = {0, 0, 0}) {
  return make_vdb_grid(name, n, n, n, std::vector<float>(static_cast<size_t>(n) * n * n, 1.0f), 0.05, {}, origin);
}

struct Measured {
  uint64_t estimate = 0;
  uint64_t measured = 0;
  uint64_t leaves = 0;
};

// The estimate of a medium reading `density` (and `emission`) from a file of `grids`, and what reading and building
// it holds.
Measured measure(const std::vector<VdbGrid>& grids, const std::string& density, const std::string& emission = "") {
  const std::vector<uint8_t> bytes = write_vdb(grids);
  const lightmap::VdbMediumSize size = lightmap::vdb_medium_size(bytes, density, emission);
  lightmap::LightmapJobSize job;
  job.vdb_media = {size};
  Measured m;
  m.estimate = lightmap::estimate_memory(job).media_bytes;
  // Every grid of the file, as OpenVDB's reader makes them (read_vdb reads them all before it keeps the named ones).
  std::vector<std::string> all;
  for (const VdbGrid& g : grids) all.push_back(g.name());
  const std::vector<VdbGrid> read = read_vdb(bytes, all);
  m.measured = bytes.size();
  for (const VdbGrid& g : read) {
    m.measured += g.impl().grid->tree().memUsage();
    m.leaves += g.impl().grid->tree().leafCount();
  }
  GridMediumSpec spec;
  spec.density = read[0];
  spec.sigma_s = Rgb{1.0};
  const GridMedium medium(spec);
  m.measured += medium.majorant_grid().cell_count() * sizeof(float);
  std::printf("%-40s leaves %7llu  estimate %10llu  measured %10llu  ratio %.2f\n",
              ::testing::UnitTest::GetInstance()->current_test_info()->name(),
              static_cast<unsigned long long>(m.leaves), static_cast<unsigned long long>(m.estimate),
              static_cast<unsigned long long>(m.measured), double(m.estimate) / double(m.measured));
  return m;
}

void expect_bound(const Measured& m) {
  EXPECT_GE(m.estimate, m.measured);
  EXPECT_LE(m.estimate, 3 * m.measured);
}

TEST(VdbMediumMemory, GrowsWithTheLeavesAndBoundsWhatTheBakeHolds) {
  Measured previous;
  for (int n : {8, 32, 64, 128}) {
    const Measured m = measure({block("density", n)}, "density");
    expect_bound(m);
    EXPECT_EQ(m.leaves, static_cast<uint64_t>(n / 8) * (n / 8) * (n / 8));
    if (previous.leaves > 0) {
      // At least the walk's 2,304 bytes a float leaf for each leaf more (vdb_structure.cpp's leaf_bytes).
      EXPECT_GE(m.estimate - previous.estimate, (m.leaves - previous.leaves) * 2304) << n;
    }
    previous = m;
  }
}

TEST(VdbMediumMemory, CountsEveryGridOfTheFileAndTheEmission) {
  // OpenVDB reads the unnamed "temperature" too before read_vdb drops it; the emission grid is kept.
  expect_bound(measure({block("density", 32), block("heat", 16), block("temperature", 64)}, "density", "heat"));
}

TEST(VdbMediumMemory, ASparseGridsMajorantCoversItsWholeBox) {
  // Two leaves 4,000 voxels apart: the majorant grid spans the box between them (at coarser cells), far more than
  // the leaves themselves.
  const VdbGrid far = make_vdb_grid("density", 8, 8, 8, std::vector<float>(512, 1.0f), 0.05);
  openvdb::FloatGrid::Ptr g = far.impl().grid->deepCopy();
  g->tree().setValueOn(openvdb::Coord(4000, 4000, 4000), 2.0f);
  const Measured m = measure({VdbGrid(adopt_float_grid(g))}, "density");
  expect_bound(m);
  EXPECT_GT(m.estimate, 4u << 20);  // the majorant alone: GridMedium::kMaxMajorantCells / 2 cells and more
}

TEST(VdbMediumMemory, AMissingGridOrABadFileIsTheWalksError) {
  const std::vector<uint8_t> bytes = write_vdb({block("density", 8)});
  try {
    lightmap::vdb_medium_size(bytes, "smoke", "");
    ADD_FAILURE() << "found a grid the file lacks";
  } catch (const bake::InvalidInput& e) {
    EXPECT_EQ(e.field(), "grids[smoke]");
    EXPECT_NE(e.problem().find("'density'"), std::string::npos) << e.what();
  }
  const std::vector<uint8_t> cut(bytes.begin(), bytes.begin() + static_cast<long>(bytes.size() / 2));
  EXPECT_THROW(lightmap::vdb_medium_size(cut, "density", ""), bake::InvalidInput);
}

}  // namespace
}  // namespace kiln::volume
