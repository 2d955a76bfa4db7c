// The VDB structure walk (bakers/volume/vdb_structure.cpp) against OpenVDB 10 itself: every file OpenVDB writes (its
// stream and file formats, each compression, active-mask variants, half floats, every value type kiln lets it read,
// instances) is accepted with the node counts OpenVDB reports; damaged files are refused with a message naming what
// was found where; every prefix of a small file and every single-byte change over its header and topology ends in
// success or InvalidInput, never a crash, a leak or an allocation beyond the bounds (the sanitizer build checks those).
// Files are made with OpenVDB and edited at offsets the walk reports, which the io::File test checks against the
// offsets OpenVDB itself stores.
//
// With KILN_WRITE_VDB_REGRESSIONS=DIR set, the test also writes the fuzz regression inputs of the three findings the
// walk fixes (tests/fuzz/regressions/vdb/) to DIR; with KILN_WRITE_VDB_SEEDS=DIR, every file it accepts, as extra
// seeds for a fuzz run (its working corpus, build-asan/fuzz/corpus/vdb/).
#include "bakers/volume/vdb_structure.h"

#include <gtest/gtest.h>

#include <openvdb/io/File.h>
#include <openvdb/io/Stream.h>
#include <openvdb/openvdb.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <unistd.h>

#include "bakers/bake/invalid_input.h"
#include "bakers/volume/vdb_file.h"

namespace kiln::volume {
namespace {

using Bytes = std::vector<uint8_t>;

Bytes stream_bytes(const openvdb::GridCPtrVec& grids,
                   uint32_t compression = openvdb::io::COMPRESS_BLOSC | openvdb::io::COMPRESS_ACTIVE_MASK) {
  openvdb::initialize();
  std::ostringstream out;
  openvdb::io::Stream stream(out);
  stream.setCompression(compression);
  stream.write(grids);
  const std::string s = out.str();
  return {s.begin(), s.end()};
}

// What OpenVDB itself reads from the bytes.
openvdb::GridPtrVecPtr openvdb_read(const Bytes& bytes) {
  std::istringstream in(std::string(bytes.begin(), bytes.end()));
  openvdb::io::Stream stream(in, /*delayLoad=*/false);
  return stream.getGrids();
}

template <typename T>
void put(Bytes& b, size_t at, T v) {
  ASSERT_LE(at + sizeof v, b.size());
  std::memcpy(b.data() + at, &v, sizeof v);
}
template <typename T>
T at(const Bytes& b, size_t offset) {
  T v{};
  std::memcpy(&v, b.data() + offset, sizeof v);
  return v;
}

// Expects the walk to refuse `bytes` on `field` with a problem containing each of `words`.
void expect_refused(const Bytes& bytes, const std::string& field, const std::vector<std::string>& words) {
  try {
    check_vdb_structure(bytes);
    ADD_FAILURE() << "accepted; expected " << field << ": " << words.front();
  } catch (const bake::InvalidInput& e) {
    EXPECT_EQ(e.field(), field) << e.what();
    for (const std::string& w : words) EXPECT_NE(e.problem().find(w), std::string::npos) << w << " in " << e.what();
  }
}

// A float grid with a few active voxels in two leaves of one lower node and an active tile.
openvdb::FloatGrid::Ptr small_grid(const std::string& name, float background = 0.0f) {
  openvdb::initialize();
  auto g = openvdb::FloatGrid::create(background);
  g->setName(name);
  auto acc = g->getAccessor();
  for (int i = 0; i < 12; ++i) acc.setValue(openvdb::Coord(i, 1, 2), 0.5f + float(i));
  g->tree().addTile(1, openvdb::Coord(128, 0, 0), 3.0f, true);  // one active 8³ tile in a lower node
  g->setTransform(openvdb::math::Transform::createLinearTransform(0.25));
  return g;
}

// The walk's counts against OpenVDB's, grid by grid, and OpenVDB reads the bytes.
void expect_accepted(const Bytes& bytes) {
  if (const char* dir = std::getenv("KILN_WRITE_VDB_SEEDS")) {
    static int n = 0;
    std::ofstream(std::filesystem::path(dir) / ("accepted_" + std::to_string(n++) + ".vdb"), std::ios::binary)
        .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  }
  const VdbStructure s = check_vdb_structure(bytes);
  const openvdb::GridPtrVecPtr grids = openvdb_read(bytes);
  ASSERT_EQ(s.grids.size(), grids->size());
  for (size_t i = 0; i < grids->size(); ++i) {
    const openvdb::GridBase& g = *(*grids)[i];
    EXPECT_EQ(s.grids[i].name, g.getName());
    EXPECT_EQ(s.grids[i].tree_type, g.type());
    if (!s.grids[i].instance_parent.empty()) continue;
    const std::vector<openvdb::Index32> nodes = g.baseTree().nodeCount();  // leaves, lower, upper, root
    ASSERT_EQ(nodes.size(), 4u);
    EXPECT_EQ(s.grids[i].leaves, int64_t(nodes[0])) << g.getName();
    EXPECT_EQ(s.grids[i].lower_nodes, int64_t(nodes[1])) << g.getName();
    EXPECT_EQ(s.grids[i].upper_nodes, int64_t(nodes[2])) << g.getName();
    // The stored box holds OpenVDB's boxes of active voxels and of leaves with active voxels (it also holds leaves
    // with none, which OpenVDB's leave out: the majorant estimate needs a box at least as large).
    openvdb::CoordBBox box = g.evalActiveVoxelBoundingBox(), leaves;
    if (g.baseTree().evalLeafBoundingBox(leaves)) box.expand(leaves);
    for (int a = 0; !box.empty() && a < 3; ++a) {
      EXPECT_LE(s.grids[i].stored_lo[a], box.min()[a]) << g.getName();
      EXPECT_GE(s.grids[i].stored_hi[a], box.max()[a]) << g.getName();
    }
  }
}

// The stored box is exactly OpenVDB's when every leaf holds an active voxel: leaves, an active tile in a lower node
// and one at the root, at negative coordinates too.
TEST(VdbStructure, TheStoredBoxIsOpenVdbsBoxOfLeavesAndActiveTiles) {
  openvdb::FloatGrid::Ptr g = small_grid("density");
  g->tree().setValueOn(openvdb::Coord(-20, -300, 7), 1.0f);
  const Bytes one = stream_bytes({g});
  const VdbStructure s = check_vdb_structure(one);
  EXPECT_EQ(s.grids[0].stored_lo, (std::array<int64_t, 3>{-24, -304, 0}));
  EXPECT_EQ(s.grids[0].stored_hi, (std::array<int64_t, 3>{135, 7, 7}));
  g->tree().addTile(3, openvdb::Coord(8192, 0, 0), 2.0f, true);  // a root tile of 4096³ voxels
  const VdbStructure t = check_vdb_structure(stream_bytes({g}));
  EXPECT_EQ(t.grids[0].stored_lo, (std::array<int64_t, 3>{-24, -304, 0}));
  EXPECT_EQ(t.grids[0].stored_hi, (std::array<int64_t, 3>{8192 + 4095, 4095, 4095}));
  // An empty grid stores nothing: lo > hi.
  const VdbStructure e = check_vdb_structure(stream_bytes({openvdb::FloatGrid::create(0.0f)}));
  EXPECT_GT(e.grids[0].stored_lo[0], e.grids[0].stored_hi[0]);
}

TEST(VdbStructure, WriteVdbOutputIsAccepted) {
  const VdbGrid d = make_vdb_grid("density", 12, 9, 5, std::vector<float>(12 * 9 * 5, 0.5f), 0.25);
  const Bytes bytes = write_vdb({d});
  const VdbStructure s = check_vdb_structure(bytes);
  EXPECT_EQ(s.file_version, 224u);
  EXPECT_FALSE(s.has_grid_offsets);
  ASSERT_EQ(s.grids.size(), 1u);
  EXPECT_EQ(s.grids[0].name, "density");
  EXPECT_EQ(s.grids[0].tree_type, "Tree_float_5_4_3");
  EXPECT_EQ(s.grids[0].end_offset, bytes.size());
  expect_accepted(bytes);
}

TEST(VdbStructure, EveryCompressionIsAccepted) {
  using namespace openvdb::io;
  const auto g = small_grid("density", 0.0f);
  for (uint32_t c : std::vector<uint32_t>{COMPRESS_NONE, COMPRESS_ZIP, COMPRESS_BLOSC, COMPRESS_ACTIVE_MASK,
                                          COMPRESS_ZIP | COMPRESS_ACTIVE_MASK, COMPRESS_BLOSC | COMPRESS_ACTIVE_MASK}) {
    SCOPED_TRACE(c);
    const Bytes bytes = stream_bytes({g}, c);
    EXPECT_EQ(check_vdb_structure(bytes).grids.at(0).compression, c);
    expect_accepted(bytes);
  }
}

// Active-mask compression stores a node's inactive values by kind (io/Compression.h's metadata byte): all
// background, all -background, one other value, a mask between two, or all values. A leaf of each.
TEST(VdbStructure, EveryActiveMaskVariantIsAccepted) {
  openvdb::initialize();
  auto g = openvdb::FloatGrid::create(1.0f);
  g->setName("levels");
  auto acc = g->getAccessor();
  for (int leaf = 0; leaf < 6; ++leaf) {
    const int x = leaf * 8;
    acc.setValue(openvdb::Coord(x, 0, 0), 5.0f);  // one active voxel a leaf; the rest inactive as below
    for (int i = 1; i < 8; ++i) {
      const openvdb::Coord c(x + i, 0, 0);
      switch (leaf) {
        case 0:
          break;  // inactive = background
        case 1:
          acc.setValueOff(c, -1.0f);
          break;  // all -background
        case 2:
          acc.setValueOff(c, 7.0f);
          break;  // one other value
        case 3:
          acc.setValueOff(c, i % 2 ? 1.0f : -1.0f);
          break;  // ±background, mask
        case 4:
          acc.setValueOff(c, i % 2 ? 1.0f : 9.0f);
          break;  // background and one other, mask
        case 5:
          acc.setValueOff(c, float(i) + 10);
          break;  // many values: all stored
      }
    }
  }
  // Make the inactive values of each leaf's other voxels match its kind too.
  for (auto leaf = g->tree().beginLeaf(); leaf; ++leaf) {
    const int kind = leaf->origin().x() / 8;
    for (auto v = leaf->beginValueOff(); v; ++v) {
      if (v.getCoord().y() == 0 && v.getCoord().z() == 0 && v.getCoord().x() % 8 != 0) continue;
      if (kind == 1) v.setValue(-1.0f);
      if (kind == 2) v.setValue(7.0f);
    }
  }
  using namespace openvdb::io;
  for (uint32_t c : std::vector<uint32_t>{COMPRESS_ACTIVE_MASK, COMPRESS_ZIP | COMPRESS_ACTIVE_MASK,
                                          COMPRESS_BLOSC | COMPRESS_ACTIVE_MASK}) {
    SCOPED_TRACE(c);
    const Bytes bytes = stream_bytes({g}, c);
    expect_accepted(bytes);
    // The walk saw each leaf's metadata byte; OpenVDB reads back every value.
    auto back = openvdb::gridPtrCast<openvdb::FloatGrid>(openvdb_read(bytes)->at(0));
    for (auto v = g->tree().cbeginValueAll(); v; ++v)
      if (v.isVoxelValue()) {
        ASSERT_EQ(back->tree().getValue(v.getCoord()), *v) << v.getCoord();
      }
  }
}

TEST(VdbStructure, EveryValueTypeAndHalfFloatsAreAccepted) {
  openvdb::initialize();
  auto f = small_grid("density");
  auto d = openvdb::DoubleGrid::create();
  d->setName("temperature");
  d->tree().setValue(openvdb::Coord(1, 2, 3), 300.0);
  auto i32 = openvdb::Int32Grid::create();
  i32->setName("id");
  i32->tree().setValue(openvdb::Coord(-40, 2, 3), 7);
  auto i64 = openvdb::Int64Grid::create();
  i64->setName("id64");
  i64->tree().setValue(openvdb::Coord(5000, 2, 3), 7);
  auto v3s = openvdb::Vec3SGrid::create();
  v3s->setName("vel");
  for (int i = 0; i < 20; ++i) v3s->tree().setValue(openvdb::Coord(i, 0, i), openvdb::Vec3s(float(i), 1, 2));
  auto v3d = openvdb::Vec3DGrid::create();
  v3d->setName("vel64");
  v3d->tree().setValue(openvdb::Coord(0, 0, 0), openvdb::Vec3d(1, 2, 3));
  auto v3i = openvdb::Vec3IGrid::create();
  v3i->setName("cell");
  v3i->tree().setValue(openvdb::Coord(0, 9, 0), openvdb::Vec3i(1, 2, 3));
  const Bytes all = stream_bytes({f, d, i32, i64, v3s, v3d, v3i});
  expect_accepted(all);
  const VdbStructure s = check_vdb_structure(all);
  const std::vector<std::string> types{"Tree_float_5_4_3", "Tree_double_5_4_3", "Tree_int32_5_4_3", "Tree_int64_5_4_3",
                                       "Tree_vec3s_5_4_3", "Tree_vec3d_5_4_3",  "Tree_vec3i_5_4_3"};
  for (size_t i = 0; i < types.size(); ++i) EXPECT_EQ(s.grids[i].tree_type, types[i]);

  // Half floats: real types read 2 bytes a component; integer types ignore the flag.
  for (auto grid : std::vector<openvdb::GridBase::Ptr>{f, d, i32, v3s, v3d, v3i}) grid->setSaveFloatAsHalf(true);
  using namespace openvdb::io;
  for (uint32_t c : std::vector<uint32_t>{COMPRESS_NONE, COMPRESS_ACTIVE_MASK, COMPRESS_ZIP,
                                          COMPRESS_BLOSC | COMPRESS_ACTIVE_MASK}) {
    SCOPED_TRACE(c);
    const Bytes half = stream_bytes({f, d, i32, v3s, v3d, v3i}, c);
    const VdbStructure h = check_vdb_structure(half);
    for (const VdbGridStructure& g : h.grids) EXPECT_TRUE(g.half_float) << g.name;
    expect_accepted(half);
  }
  // kiln's own reader takes a half-float density (values rounded to half precision: 0.5 + i is exact in half).
  const std::vector<VdbGrid> back = read_vdb(stream_bytes({f}), {"density"});
  EXPECT_EQ(back[0].value(3, 1, 2), 3.5f);
}

TEST(VdbStructure, AnIoFileWithGridOffsetsIsAcceptedAndItsOffsetsAreTheWalks) {
  openvdb::initialize();
  const auto path =
      std::filesystem::temp_directory_path() / ("kiln_vdb_structure_" + std::to_string(getpid()) + ".vdb");
  auto vel = openvdb::Vec3SGrid::create();
  vel->setName("velocity");
  vel->tree().setValue(openvdb::Coord(3, 4, 5), openvdb::Vec3s(1, 0, 0));
  openvdb::io::File file(path.string());
  file.write({small_grid("density"), small_grid("temperature"), vel});
  file.close();
  std::ifstream in(path, std::ios::binary);
  const Bytes bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::filesystem::remove(path);
  const VdbStructure s = check_vdb_structure(bytes);
  EXPECT_TRUE(s.has_grid_offsets);
  ASSERT_EQ(s.grids.size(), 3u);
  EXPECT_EQ(s.grids[2].tree_type, "Tree_vec3s_5_4_3");
  expect_accepted(bytes);
  // OpenVDB's own offsets, the descriptor's three just before the grid's compression flags, are where the walk
  // found each part.
  for (const VdbGridStructure& g : s.grids) {
    EXPECT_EQ(at<int64_t>(bytes, g.start_offset - 24), int64_t(g.start_offset)) << g.name;
    EXPECT_EQ(at<int64_t>(bytes, g.start_offset - 16), int64_t(g.buffers_offset)) << g.name;
    EXPECT_EQ(at<int64_t>(bytes, g.start_offset - 8), int64_t(g.end_offset)) << g.name;
  }
  // An offset that disagrees with the file is refused.
  Bytes moved = bytes;
  put<int64_t>(moved, s.grids[1].start_offset - 16, int64_t(s.grids[1].buffers_offset) + 4);
  expect_refused(moved, "bytes", {"grid 'temperature' (the 2nd of 3)", "block offset is", "at byte"});
}

TEST(VdbStructure, InstancesAreAcceptedWithTheirParent) {
  auto a = small_grid("density");
  auto b = a->copyGrid();  // shares a's tree: written as an instance
  b->setName("density_copy");
  const Bytes bytes = stream_bytes({a, b});
  const VdbStructure s = check_vdb_structure(bytes);
  ASSERT_EQ(s.grids.size(), 2u);
  EXPECT_EQ(s.grids[1].instance_parent, "density");
  expect_accepted(bytes);
  // Renaming the parent leaves the instance without one.
  Bytes orphan = bytes;
  const size_t name_at = 65;  // after the header, an empty file metadata count and the grid count
  ASSERT_EQ(at<uint32_t>(orphan, name_at), 7u);
  orphan[name_at + 4] = 'D';
  expect_refused(orphan, "bytes", {"grid 'density_copy' shares the tree of 'density'"});
}

TEST(VdbStructure, GridsOfOtherTypesAreRefusedByName) {
  openvdb::initialize();
  auto b = openvdb::BoolGrid::create();
  b->setName("mask");
  b->tree().setValue(openvdb::Coord(0), true);
  expect_refused(stream_bytes({small_grid("density"), b}), "grids[mask]", {"type 'Tree_bool_5_4_3'", "vec3s"});
  auto m = openvdb::MaskGrid::create();
  m->setName("sel");
  m->tree().setValueOn(openvdb::Coord(0));
  expect_refused(stream_bytes({m}), "grids[sel]", {"type 'Tree_mask_5_4_3'"});
}

// The offsets of a single-grid Stream file's parts: header 57 bytes, then file metadata (here empty, 4 bytes).
struct Layout {
  Bytes bytes;
  VdbGridStructure g;
  size_t background() const { return g.tree_offset + 4; }
  size_t tiles() const { return background() + 4; }
  size_t first_child() const { return tiles() + 8; }         // its origin
  size_t upper_masks() const { return first_child() + 12; }  // child mask, then value mask
  size_t upper_meta() const { return upper_masks() + 8192; }
};
Layout layout(const Bytes& bytes) { return {bytes, check_vdb_structure(bytes).grids.at(0)}; }

TEST(VdbStructure, DamagedHeadersAreRefusedSayingWhere) {
  const Bytes good = stream_bytes({small_grid("density")});
  Bytes b = good;
  put<uint32_t>(b, 8, 221);
  expect_refused(b, "bytes", {"file format version is 221", "222 to 224", "at byte 8"});
  b = good;
  b[30] = 'x';
  expect_refused(b, "bytes", {"UUID", "at byte 30"});
  b = good;
  put<uint32_t>(b, 57, 1000);  // file metadata count: the grid count and the grid's name read as items
  expect_refused(b, "bytes", {"the file's 1st metadata item", "are left in the file"});
  b = good;
  put<uint32_t>(b, 57, 70000);
  expect_refused(b, "bytes", {"the file declares 70000 metadata items", "at most 65536", "at byte 57"});
  b = good;
  put<int32_t>(b, 61, -1);  // grid count
  expect_refused(b, "bytes", {"declares -1 grids", "at byte 61"});
  b = good;
  put<int32_t>(b, 61, 1 << 30);
  expect_refused(b, "bytes", {"declares 1073741824 grids"});
  b = good;
  put<uint32_t>(b, 65, 0x7ffffff0u);  // the grid name's length
  expect_refused(b, "bytes", {"a grid's name declares 2147483632 bytes", "at byte 65"});
}

TEST(VdbStructure, DamagedGridPartsAreRefusedSayingWhat) {
  const Layout l = layout(stream_bytes({small_grid("density")}));
  Bytes b = l.bytes;
  put<uint32_t>(b, l.g.start_offset, 0x10);
  expect_refused(b, "bytes", {"grid 'density' (the 1st of 1)", "compression flags are 16"});
  // Root: tiles at an origin that is no multiple of 4096, two entries at one origin, children out of order.
  b = l.bytes;
  put<int32_t>(b, l.first_child(), 5);
  expect_refused(b, "bytes", {"origin (5, 0, 0)", "multiples of 4096"});
  b = l.bytes;
  put<uint32_t>(b, l.tiles(), 1000000);
  expect_refused(b, "bytes", {"the root declares 1000000 tiles and 1 children"});
  // The upper node: a mask bit both child and tile, a metadata byte beyond 6, a child mask full of children.
  b = l.bytes;
  b[l.upper_masks()] |= 1;
  b[l.upper_masks() + 4096] |= 1;
  expect_refused(b, "bytes", {"both a child and an active tile"});
  b = l.bytes;
  b[l.upper_meta()] = 7;
  expect_refused(b, "bytes", {"metadata byte is 7", "0 to 6", "at byte " + std::to_string(l.upper_meta())});
  b = l.bytes;
  std::memset(b.data() + l.upper_masks(), 0xff, 4096);
  expect_refused(b, "bytes", {"an upper internal node declares 32768 children"});
}

// The finding of tests/fuzz/regressions/vdb/blosc_chunk_claims_140_tb.vdb, and every other lie a chunk's size can
// tell: more bytes than the file has, a raw size other than the node's, a Blosc header that disagrees.
TEST(VdbStructure, ChunkSizesAreCheckedAgainstTheFileAndTheNode) {
  using namespace openvdb::io;
  const Layout blosc = layout(stream_bytes({small_grid("density")}, COMPRESS_BLOSC | COMPRESS_ACTIVE_MASK));
  // The first leaf buffer: 64 bytes of mask, the metadata byte, then (metadata 0: nothing else) the chunk's size.
  const size_t leaf = blosc.g.buffers_offset;
  ASSERT_EQ(blosc.bytes[leaf + 64], 0);
  const size_t size_at = leaf + 65;
  Bytes b = blosc.bytes;
  put<int64_t>(b, size_at, int64_t(0x7ffe3e4f3aa8));
  expect_refused(b, "bytes",
                 {"leaf 0's buffer's values chunk declares 140729943800488 compressed bytes", "are left in the file",
                  "at byte " + std::to_string(size_at)});
  b = blosc.bytes;
  put<int64_t>(b, size_at, -100);
  expect_refused(b, "bytes", {"declares 100 uncompressed bytes; the node holds 32"});
  b = blosc.bytes;
  put<int64_t>(b, size_at, 100);
  expect_refused(b, "bytes", {"declares 100 compressed bytes for 32 bytes of values; at most 48 are allowed"});
  b = blosc.bytes;
  put<int64_t>(b, size_at, std::numeric_limits<int64_t>::min());
  expect_refused(b, "bytes", {"declares 2^63 uncompressed bytes"});
  b = blosc.bytes;
  const int64_t n = at<int64_t>(b, size_at);
  ASSERT_GT(n, 16);
  put<uint32_t>(b, size_at + 8 + 4, 4096);  // the Blosc header's uncompressed size
  expect_refused(b, "bytes", {"is a Blosc chunk of 4096 bytes; it must hold 32"});
  b = blosc.bytes;
  put<uint32_t>(b, size_at + 8 + 12, uint32_t(n) + 1);  // its compressed size
  expect_refused(b, "bytes", {"Blosc header says " + std::to_string(n + 1)});

  const Layout zip = layout(stream_bytes({small_grid("density")}, COMPRESS_ZIP));
  // Without active-mask compression every value is stored: 512 floats, zipped.
  const size_t zip_size_at = zip.g.buffers_offset + 65;
  b = zip.bytes;
  put<int64_t>(b, zip_size_at, 5000);
  expect_refused(b, "bytes", {"declares 5000 compressed bytes;", "are left in the file"});

  // An internal node's values that do not decompress: OpenVDB would throw inside RootNode::readTopology and leak
  // the root's child, so the walk decompresses them (the first lower node's 4,096 values, zipped: the upper node's
  // values chunk, then the lower node's masks and metadata byte, come before).
  const size_t upper_chunk = zip.upper_meta() + 1;
  const size_t lower_chunk = upper_chunk + 8 + size_t(at<int64_t>(zip.bytes, upper_chunk)) + 1024 + 1;
  ASSERT_GT(at<int64_t>(zip.bytes, lower_chunk), 16);
  b = zip.bytes;
  put<uint32_t>(b, lower_chunk + 8 + 6, 0xffffffffu);
  expect_refused(b, "bytes",
                 {"a lower internal node's values chunk does not decompress to its 16384 bytes",
                  "at byte " + std::to_string(lower_chunk)});

  const Layout raw = layout(stream_bytes({small_grid("density")}, COMPRESS_NONE));
  b = raw.bytes;
  b.resize(b.size() - 1);
  expect_refused(b, "bytes", {"the file ends inside leaf 1's buffer's values chunk (2048 bytes needed, 2047 left)"});
}

TEST(VdbStructure, MetadataAndTransformsAreChecked) {
  auto g = small_grid("density");
  g->insertMeta("flag", openvdb::BoolMetadata(true));
  g->insertMeta("note", openvdb::StringMetadata("hello"));
  const Bytes good = stream_bytes({g});
  auto find = [&](const Bytes& bytes, const std::string& s) {
    const auto it = std::search(bytes.begin(), bytes.end(), s.begin(), s.end());
    EXPECT_NE(it, bytes.end()) << s;
    return size_t(it - bytes.begin());
  };
  // "flag", then "bool" (4-byte length + 4), then the size (1) and the value.
  const size_t flag_size = find(good, "bool") + 4;
  ASSERT_EQ(at<uint32_t>(good, flag_size), 1u);
  Bytes b = good;
  put<uint32_t>(b, flag_size, 8);
  expect_refused(b, "bytes", {"metadata 'flag' (bool) declares 8 bytes; a bool holds 1"});
  b = good;
  b[flag_size + 4] = 2;
  expect_refused(b, "bytes", {"metadata 'flag' (bool) holds 2; a bool is 0 or 1"});
  const size_t note_size = find(good, "hello") - 4;
  b = good;
  put<uint32_t>(b, note_size, 0x40000000u);
  expect_refused(b, "bytes", {"metadata 'note' (string) declares 1073741824 bytes"});
  // The map type: an unknown name of the same length.
  b = good;
  const size_t map = find(good, "UniformScaleMap");
  std::memcpy(b.data() + map, "UniformScaleMAP", 15);
  expect_refused(b, "bytes", {"map is of type 'UniformScaleMAP', which OpenVDB does not know"});
  b = good;
  put<double>(b, map + 15, std::numeric_limits<double>::quiet_NaN());
  expect_refused(b, "bytes", {"the transform's map holds a non-finite number"});
  // The half-float flag in the type name without the metadata OpenVDB reads it from.
  openvdb::initialize();
  auto h = small_grid("density");
  h->setSaveFloatAsHalf(true);
  b = stream_bytes({h});
  const size_t type = find(b, "Tree_float_5_4_3_HalfFloat");
  std::memcpy(b.data() + type + 16, "_HalfFloaT", 10);  // no longer the suffix: the metadata still says half
  expect_refused(b, "grids[density]", {"type 'Tree_float_5_4_3_HalfFloaT'"});
  b = stream_bytes({h});
  const size_t half_meta = find(b, "is_saved_as_half_float") + 22 + 4 + 4 + 4;  // name, "bool", size
  ASSERT_EQ(b[half_meta], 1);
  b[half_meta] = 0;
  expect_refused(b, "bytes", {"type name says it is stored as half floats", "metadata says not"});
}

// A grid of more leaves than kVdbMaxLeavesPerGrid: refused by name before OpenVDB allocates them.
TEST(VdbStructure, TooManyLeavesAreRefusedByGrid) {
  openvdb::initialize();
  auto g = openvdb::FloatGrid::create();
  g->setName("dust");
  auto acc = g->getAccessor();
  int leaves = 0;
  for (int x = 0; leaves <= kVdbMaxLeavesPerGrid; x += 8)
    for (int y = 0; y < 512 && leaves <= kVdbMaxLeavesPerGrid; y += 8, ++leaves) acc.setValue({x, y, 0}, 1.0f);
  const Bytes bytes = stream_bytes({g});
  // First by the delayed-load metadata OpenVDB writes into every grid (the leaves, counted), before the tree.
  expect_refused(
      bytes, "grids[dust]",
      {"file_delayed_load' (__delayedload) counts 131073 leaves", "at most 131072 (67108864 stored voxels)"});
  // Without it (its type renamed, so OpenVDB skips it as unknown), by the leaves of the topology.
  Bytes unnamed = bytes;
  const std::string type = "__delayedload";
  const auto it = std::search(unnamed.begin(), unnamed.end(), type.begin(), type.end());
  ASSERT_NE(it, unnamed.end());
  *(it + 2) = 'X';
  expect_refused(unnamed, "grids[dust]", {"more than 131072 leaf nodes", "at most 131072 (67108864 stored voxels)"});
}

// Copies the single root child of `l` (an upper node with one lower node and one leaf) `n` times at origins 4096
// apart, and its leaf buffer with it: OpenVDB allocates an upper and a lower node for each leaf.
Bytes scattered(const Layout& l, int n) {
  Bytes out(l.bytes.begin(), l.bytes.begin() + std::ptrdiff_t(l.tiles()));
  auto append = [&](const void* p, size_t size) {
    const auto* c = static_cast<const uint8_t*>(p);
    out.insert(out.end(), c, c + size);
  };
  const uint32_t counts[2] = {0, uint32_t(n)};
  append(counts, 8);
  for (int i = 0; i < n; ++i) {
    const int32_t origin[3] = {4096 * i, 0, 0};
    append(origin, 12);
    append(l.bytes.data() + l.upper_masks(), l.g.buffers_offset - l.upper_masks());
  }
  for (int i = 0; i < n; ++i) append(l.bytes.data() + l.g.buffers_offset, l.g.end_offset - l.g.buffers_offset);
  return out;
}

Layout one_leaf() {
  openvdb::initialize();
  auto g = openvdb::FloatGrid::create();
  g->setName("density");
  g->tree().setValue(openvdb::Coord(1, 2, 3), 1.0f);
  return layout(stream_bytes({g}));
}

TEST(VdbStructure, LeavesScatteredOneToAnUpperNodeAreBoundedByTheInternalNodeBudget) {
  const Layout l = one_leaf();
  ASSERT_EQ(l.g.upper_nodes, 1);
  ASSERT_EQ(l.g.leaves, 1);
  // A few are a valid file that OpenVDB reads as that many leaves.
  const Bytes few = scattered(l, 3);
  const VdbStructure s = check_vdb_structure(few);
  EXPECT_EQ(s.grids[0].upper_nodes, 3);
  EXPECT_EQ(openvdb_read(few)->at(0)->baseTree().leafCount(), 3u);
  // An upper node of a float tree costs 532,480 bytes, a lower one 66,560, a root entry 100: 449 of them pass 256 MiB.
  expect_refused(scattered(l, 449), "bytes", {"brings the file's internal nodes to", "at most 268435456"});
  const Bytes most = scattered(l, 448);
  EXPECT_EQ(check_vdb_structure(most).internal_node_bytes, 448 * (532480 + 66560 + 100));
}

// Every prefix of a small file, and every single-byte change over its header and topology, ends in success or
// InvalidInput from read_vdb: never another exception, a crash, or (under the sanitizers) a leak or a huge
// allocation. Three changes a byte: its low bit, its high bit, all its bits.
TEST(VdbStructure, EveryPrefixAndEveryByteChangeEndsCleanly) {
  openvdb::initialize();
  auto g = openvdb::FloatGrid::create();
  g->setName("density");
  g->tree().setValue(openvdb::Coord(1, 2, 3), 1.0f);
  g->tree().setValue(openvdb::Coord(9, 2, 3), 2.0f);
  auto e = openvdb::FloatGrid::create();
  e->setName("emission");
  e->tree().setValue(openvdb::Coord(-700, 2, 3), 1.0f);
  const Bytes good = stream_bytes({g, e});
  ASSERT_NO_THROW(read_vdb(good, {"density", "emission"}));
  int refused = 0;
  auto run = [&](const Bytes& b) {
    try {
      read_vdb(b, {"density", "emission"});
    } catch (const bake::InvalidInput&) {
      ++refused;
    }
  };
  for (size_t n = 0; n < good.size(); ++n) run(Bytes(good.begin(), good.begin() + std::ptrdiff_t(n)));
  EXPECT_EQ(refused, int(good.size()));  // every proper prefix is cut short
  const VdbStructure s = check_vdb_structure(good);
  for (size_t i = 0; i < s.grids[0].buffers_offset; ++i)
    for (uint8_t flip : {0x01, 0x80, 0xff}) {
      Bytes b = good;
      b[i] ^= flip;
      run(b);
    }
}

// The fuzz regression inputs of the three findings, refused with their messages (and, with
// KILN_WRITE_VDB_REGRESSIONS set, written).
TEST(VdbStructure, TheFindingsRegressionInputsAreRefused) {
  const std::filesystem::path dir = std::filesystem::path(KILN_SOURCE_DIR) / "tests/fuzz/regressions/vdb";
  if (const char* out = std::getenv("KILN_WRITE_VDB_REGRESSIONS")) {
    const Layout l = one_leaf();
    const Bytes many = scattered(l, 460);
    std::ofstream(std::filesystem::path(out) / "leaves_scattered_one_to_an_upper_node.vdb", std::ios::binary)
        .write(reinterpret_cast<const char*>(many.data()), std::streamsize(many.size()));
    // A file cut inside its topology (30 bytes before its leaf buffers, in the last lower node's value mask): OpenVDB
    // allocated the root's child, then the read threw and leaked it.
    const Layout two = layout(stream_bytes({small_grid("density")}));
    const Bytes cut(two.bytes.begin(), two.bytes.begin() + std::ptrdiff_t(two.g.buffers_offset - 30));
    std::ofstream(std::filesystem::path(out) / "topology_cut_short_leaks_a_root_child.vdb", std::ios::binary)
        .write(reinterpret_cast<const char*>(cut.data()), std::streamsize(cut.size()));
  }
  auto read = [&](const std::string& name) {
    std::ifstream in(dir / name, std::ios::binary);
    EXPECT_TRUE(in) << name;
    return Bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  };
  auto refused = [&](const std::string& name, const std::vector<std::string>& words) {
    SCOPED_TRACE(name);
    const Bytes b = read(name);
    expect_refused(b, "bytes", words);
    try {
      read_vdb(b, {"density", "emission"});
      ADD_FAILURE() << "read_vdb accepted " << name;
    } catch (const bake::InvalidInput& e) {
      EXPECT_EQ(e.field(), "bytes") << e.what();
    }
  };
  // The seed density_2x2x2.vdb with one byte changed: a second child bit in an upper node's mask, which led OpenVDB
  // to read a lower node and a leaf from the bytes after, and a chunk size of 140 TB among them.
  refused("blosc_chunk_claims_140_tb.vdb", {"an upper internal node declares 2 children", "at byte 631"});
  refused("leaves_scattered_one_to_an_upper_node.vdb", {"brings the file's internal nodes to", "at most 268435456"});
  // Found by the fuzzer after the walk: a zipped internal node's values changed by one byte (a seed the io::File test
  // accepts), which OpenVDB decompresses inside RootNode::readTopology, throwing and leaking the root's child.
  refused("zip_values_of_an_internal_node_do_not_decompress.vdb", {"internal node's values chunk does not decompress"});
  refused("topology_cut_short_leaks_a_root_child.vdb", {"the file ends inside a lower internal node's value mask"});
}

}  // namespace
}  // namespace kiln::volume
