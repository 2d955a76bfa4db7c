// The structure of an OpenVDB file, walked from its bytes before OpenVDB reads them. OpenVDB 10's stream reader
// trusts what a file declares: it allocates a compressed chunk's declared size before reading it, allocates every
// node of the topology before reading the node (and leaks the root's children when a read throws), and lets a few MB
// of topology declare gigabytes of internal nodes. The walk follows OpenVDB 10.0.1's reader (io/Archive.cc,
// io/Stream.cc, io/GridDescriptor.cc, io/Compression.h, tree/RootNode.h, tree/InternalNode.h, tree/LeafNode.h,
// MetaMap.cc, math/Transform.cc) byte for byte and refuses anything that reader would throw on while it reads the
// topology, read past, or allocate beyond the bounds below, so that OpenVDB only sees files it reads within them
// (internal nodes' compressed values are decompressed with OpenVDB's own functions for that; leaf buffers, read
// after the topology, are not, and OpenVDB's exception for one that does not decompress leaks nothing). The rules
// are in docs/MEDIA.md ("Validation").
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "bakers/volume/medium_bounds.h"

namespace kiln::volume {

// Leaf nodes in one grid: the stored-voxel bound read_vdb puts on the grids it reads (512 voxels a leaf), applied to
// every grid of the file, since OpenVDB reads them all.
inline constexpr int64_t kVdbMaxLeavesPerGrid = limits::kVdbActiveVoxels.hi / 512;
// Bytes OpenVDB may allocate for the internal nodes and root entries of all the file's trees: an upper node of a
// float tree costs about 0.5 MB, a lower one about 64 KB, whatever few bytes of topology declared them. 256 MiB
// holds some 4,000 lower nodes of float trees, far more than a dense grid of kVdbMaxLeavesPerGrid leaves needs
// (it needs 32 when its leaves are packed, one per leaf only when they are scattered).
inline constexpr int64_t kVdbInternalNodeBytes = int64_t{256} << 20;
// Grids in one file, and metadata items over all its metadata maps: OpenVDB reserves a descriptor per declared grid
// and makes a grid, a tree and a map entry per grid and item, from as little as 13 bytes of file each.
inline constexpr int64_t kVdbMaxGrids = 4096;
inline constexpr int64_t kVdbMaxMetadataItems = 65536;
// Bytes OpenVDB may allocate for all the file's trees (leaves included) and their delayed-load metadata: three float
// grids and a vec3s one of kVdbMaxLeavesPerGrid leaves each, a smoke simulation's frame at kiln's largest, take 1.6
// GiB.
inline constexpr int64_t kVdbTreeBytes = int64_t{2} << 30;

// One grid as the walk found it.
struct VdbGridStructure {
  std::string name;             // the descriptor's name (before any "\x1e" suffix OpenVDB adds to duplicates)
  std::string unique_name;      // the name with that suffix, which instances name their parent by
  std::string tree_type;        // "Tree_float_5_4_3", without the "_HalfFloat" suffix
  bool half_float = false;      // values stored as 16-bit floats (float, double, vec3s, vec3d trees)
  std::string instance_parent;  // non-empty for a grid that shares another grid's tree (it stores none)
  uint32_t compression = 0;     // OpenVDB's flags: 1 zip, 2 active mask, 4 blosc
  std::string map_type;         // the transform's map, "UniformScaleMap", ...
  int64_t root_tiles = 0;
  int64_t upper_nodes = 0;
  int64_t lower_nodes = 0;
  int64_t leaves = 0;
  // The index-space box [lo, hi] (inclusive) of every leaf and active tile, as OpenVDB's evalLeafBoundingBox and
  // evalActiveVoxelBoundingBox together find it (vdb_grid.cpp's stored box); lo > hi when the tree holds none.
  std::array<int64_t, 3> stored_lo{INT64_MAX, INT64_MAX, INT64_MAX};
  std::array<int64_t, 3> stored_hi{INT64_MIN, INT64_MIN, INT64_MIN};
  // Byte offsets of the grid's parts as the walk found them: its compression flags (where io::File's grid offset
  // points), its tree (the buffer count; 0 for an instance), its leaf buffers (io::File's block offset) and its end.
  size_t start_offset = 0;
  size_t tree_offset = 0;
  size_t buffers_offset = 0;
  size_t end_offset = 0;
};

struct VdbStructure {
  uint32_t file_version = 0;      // OpenVDB's file format version (224 for OpenVDB 4 to 10)
  bool has_grid_offsets = false;  // written by io::File (seekable), not by io::Stream
  std::vector<VdbGridStructure> grids;
  int64_t internal_node_bytes = 0;  // what OpenVDB will allocate, at most, for internal nodes and root entries
  int64_t tree_bytes = 0;           // ... for whole trees
};

// Walks the bytes of a .vdb file (OpenVDB's file or stream format, format versions 222 to 224) and returns what it
// found. Throws bake::InvalidInput with field "bytes" for a file that is damaged, cut short, or beyond the bounds
// above as a whole (saying what was found at which byte offset and what is allowed), and "grids[NAME]" for a grid
// kiln does not read: a tree type other than float, double, int32, int64, vec3s, vec3d and vec3i trees of OpenVDB's
// standard 5-4-3 configuration (bool, mask, point and other trees are refused), or more than kVdbMaxLeavesPerGrid
// leaves.
VdbStructure check_vdb_structure(std::span<const uint8_t> bytes);

}  // namespace kiln::volume
