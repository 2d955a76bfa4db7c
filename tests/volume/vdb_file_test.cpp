// Reading and writing .vdb files in memory: a round trip keeps every voxel, the transform and the names; every
// validation rule rejects its case with a message naming the grid and the limit; bad values are replaced and
// counted. Files that break a rule are made with OpenVDB directly (this test links it; the library's headers don't).
#include "bakers/volume/vdb_file.h"

#include <gtest/gtest.h>

#include <openvdb/io/Stream.h>
#include <openvdb/openvdb.h>

#include <cmath>
#include <sstream>

#include "bakers/bake/invalid_input.h"

namespace kiln::volume {
namespace {

std::vector<uint8_t> stream_bytes(const openvdb::GridCPtrVec& grids) {
  std::ostringstream out;
  openvdb::io::Stream(out).write(grids);
  const std::string s = out.str();
  return {s.begin(), s.end()};
}

// Expects read_vdb to throw InvalidInput on field `field` with a problem containing `words`.
void expect_rejected(const std::vector<uint8_t>& bytes, const std::vector<std::string>& names, const std::string& field,
                     const std::string& words) {
  try {
    read_vdb(bytes, names);
    ADD_FAILURE() << "accepted; expected " << field << ": " << words;
  } catch (const bake::InvalidInput& e) {
    EXPECT_EQ(e.field(), field) << e.what();
    EXPECT_NE(e.problem().find(words), std::string::npos) << e.what();
  }
}

// `count` values, some zero (left unstored), the rest distinct.
std::vector<float> ramp(int count) {
  std::vector<float> v(count);
  for (size_t i = 0; i < v.size(); ++i) v[i] = (i % 7 == 0) ? 0.0f : 0.001f * float(i);
  return v;
}

// Every voxel equal (bit for bit: floats are stored as they are, lossless compression), names, counts and the
// index-to-world transform equal.
TEST(VdbFile, ReadBackEqualsWhatWasWritten) {
  const VdbGrid density = make_vdb_grid("density", 12, 9, 5, ramp(12 * 9 * 5), 0.25, {1, -2, 3}, {-4, 0, 7});
  const VdbGrid emission = make_vdb_grid("emission", 4, 4, 4, std::vector<float>(64, 2.5f), 0.5);
  const std::vector<uint8_t> bytes = write_vdb({density, emission});
  const std::vector<VdbGrid> back = read_vdb(bytes, {"emission", "density"});
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[0].name(), "emission");
  EXPECT_EQ(back[1].name(), "density");
  const VdbGrid& d = back[1];
  EXPECT_EQ(d.active_voxel_count(), density.active_voxel_count());
  EXPECT_EQ(d.index_lo(), density.index_lo());
  EXPECT_EQ(d.index_hi(), density.index_hi());
  EXPECT_EQ(d.voxel_size(), density.voxel_size());
  EXPECT_EQ(d.index_to_world({3, 4, 5}), density.index_to_world({3, 4, 5}));
  for (int k = -1; k <= 13; ++k)
    for (int j = -1; j <= 10; ++j)
      for (int i = -5; i <= 9; ++i) ASSERT_EQ(d.value(i, j, k), density.value(i, j, k)) << i << " " << j << " " << k;
  EXPECT_EQ(back[0].value(3, 3, 3), 2.5f);
}

TEST(VdbFile, RejectsBytesThatAreNotAVdbFile) {
  expect_rejected({}, {"density"}, "bytes", "1 to");
  expect_rejected({'V', 'D', 'B'}, {"density"}, "bytes", "magic number");
  std::vector<uint8_t> bytes = write_vdb({make_vdb_grid("density", 8, 8, 8, ramp(512), 0.1)});
  bytes.resize(bytes.size() / 2);  // cut in the middle of the grid: found by the structure walk, before OpenVDB
  expect_rejected(bytes, {"density"}, "bytes", "grid 'density' (the 1st of 1): the root declares");
}

TEST(VdbFile, RejectsMissingDuplicateAndWronglyTypedGrids) {
  const std::vector<uint8_t> bytes = write_vdb({make_vdb_grid("density", 4, 4, 4, ramp(64), 0.1)});
  expect_rejected(bytes, {"smoke"}, "grids[smoke]", "no such grid; the file holds 'density'");
  expect_rejected(bytes, {"density", "density"}, "grids[density]", "named twice");
  auto vec = openvdb::Vec3SGrid::create();
  vec->setName("velocity");
  vec->tree().setValue(openvdb::Coord(1, 2, 3), openvdb::Vec3s(1, 0, 0));
  expect_rejected(stream_bytes({vec}), {"velocity"}, "grids[velocity]", "kiln reads float grids");
}

TEST(VdbFile, RejectsBadBackgroundTransformAndSizes) {
  openvdb::initialize();
  auto fog = openvdb::FloatGrid::create(0.5f);  // a non-zero background would fill all space
  fog->setName("density");
  expect_rejected(stream_bytes({fog}), {"density"}, "grids[density]", "background");
  auto huge_voxels = openvdb::FloatGrid::create(0.0f);
  huge_voxels->setName("density");
  huge_voxels->setTransform(openvdb::math::Transform::createLinearTransform(1e7));
  expect_rejected(stream_bytes({huge_voxels}), {"density"}, "grids[density]", "voxel edges");
  // One active tile of an upper internal node: 128³ ≈ 2.1e6 voxels stored as a single value, so a tiny file
  // declares 2^21 active voxels; 64 such tiles pass the bound 2^26.
  auto tiles = openvdb::FloatGrid::create(0.0f);
  tiles->setName("density");
  tiles->tree().fill(openvdb::CoordBBox(openvdb::Coord(0), openvdb::Coord(511)), 1.0f, true);
  expect_rejected(stream_bytes({tiles}), {"density"}, "grids[density]", "active");
  auto wide = openvdb::FloatGrid::create(0.0f);
  wide->setName("density");
  wide->tree().setValue(openvdb::Coord(0, 0, 0), 1.0f);
  wide->tree().setValue(openvdb::Coord(200000, 0, 0), 1.0f);
  expect_rejected(stream_bytes({wide}), {"density"}, "grids[density]", "spans");
}

// NaN, ±infinity and negative voxels read as 0, counted per kind; a file holding them is accepted. (make_vdb_grid
// replaces them too, so the file is made with OpenVDB.)
TEST(VdbFile, NonFiniteAndNegativeVoxelsAreReplacedAndCounted) {
  openvdb::initialize();
  auto grid = openvdb::FloatGrid::create(0.0f);
  grid->setName("density");
  auto acc = grid->getAccessor();
  for (int i = 0; i < 8; ++i) acc.setValue(openvdb::Coord(i, 0, 0), 1.0f);
  acc.setValue(openvdb::Coord(3, 0, 0), NAN);
  acc.setValue(openvdb::Coord(4, 0, 0), INFINITY);
  acc.setValue(openvdb::Coord(5, 0, 0), -INFINITY);
  acc.setValue(openvdb::Coord(6, 0, 0), -2.0f);
  const std::vector<VdbGrid> back = read_vdb(stream_bytes({grid}), {"density"});
  EXPECT_EQ(back[0].replaced_non_finite(), 3);
  EXPECT_EQ(back[0].replaced_negative(), 1);
  for (int i = 3; i <= 6; ++i) EXPECT_EQ(back[0].value(i, 0, 0), 0.0f);
  EXPECT_EQ(back[0].value(2, 0, 0), 1.0f);
}

}  // namespace
}  // namespace kiln::volume
