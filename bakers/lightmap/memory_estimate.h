// What a lightmap bake will hold at its peak, estimated before anything is decoded or allocated, from what a job
// spec says: the texels of each lightmap, the triangles traced, the bytes of the input blobs and the outputs asked
// for. The daemon refuses a job whose estimate exceeds its memory limit, and runs jobs together only while the sum of
// their estimates fits (so a job that fits is never killed by the kernel for memory).
//
// The model, every figure from the sizes of the structures the bake allocates (memory_estimate.cpp):
//  - untiled (tile_size 0), per texel of each lightmap (every texel counted, as if the charts covered the whole
//    map; with atlas pages, each of max_pages pages of page_size² texels, since how many the packer fills is not
//    known before the bake): its sample points (5 of them) and the bake's state, held to the end; while
//    that lightmap is rasterized and probed for leaks, the fragments (twice, while sorted) and the leak results; then
//    one page's results (lightmap_results.h) at a time while the pages are written, with its seams (their search over
//    the page's triangles, then the stitcher's lookups, matrix and factors: at most seam_bytes, counting every baking
//    triangle); and the output images, raw and encoded: one page's when the outputs stream
//    (bake::BakeControl::output_sink), else every page's, which the bake then holds until it returns.
//  - tiled (tile_size > 0: a page is sampled a tile of tile_size² texels at a time, lightmap_bake.cpp): the state and
//    the set-up's transient of one tile, the results of one page, the outputs as above, and the tiles' bins of
//    triangles. Light tracing is off in a tiled bake (its sums would be held for every texel), so its bytes are not
//    counted there.
//  - per traced triangle: Embree's BVH, vertex and index buffers and the tracer's own records, at the peak of the
//    BVH build, and a world-space copy while the triangle is rasterized. Triangles smaller than a texel give the
//    texels they cover a sample point each (1.5 a triangle counted), more than the 5 a texel counted above where a
//    dense mesh bakes into few texels: those beyond are counted as if all were in the texels held at once
//    (edge_point_bytes).
//  - the input blobs as bytes, the meshes decoded (in double precision, in up to three copies while the scene is
//    checked) and the textures decoded at 24 bytes a texel, their texel count taken as the encoded size (an 8-bit
//    image compresses to about a byte a texel). That last term is an estimate, not a bound: an image that compresses
//    far better than that decodes to more.
//  - per VDB medium (vdb_medium_size): the .vdb file's bytes, every grid's tree in it (OpenVDB reads them all; the
//    medium keeps the density and emission grids) at the structure walk's bytes per node (volume::VdbStructure:
//    2,304 a float leaf, about 66 KB a lower internal node, 1 MB an upper one), and the density's majorant grid, 4
//    bytes a cell of 8³ voxels over the box of its leaves and active tiles (grid_medium.cpp). Held from the inputs'
//    reading to the bake's end, beside the rest.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "bakers/scene/scene.h"

namespace kiln::lightmap {

// A VDB medium, as its file's structure says before OpenVDB reads it.
struct VdbMediumSize {
  uint64_t file_bytes = 0;      // the .vdb blob, held while its grids are read
  uint64_t tree_bytes = 0;      // every grid's tree in the file (volume::VdbStructure::tree_bytes)
  uint64_t majorant_cells = 0;  // of the density's majorant grid (volume::GridMedium::majorant_cells)
};

// The size of a VDB medium reading `density_grid` (and `emission_grid` when not empty) from the .vdb file `bytes`,
// walked without OpenVDB allocating anything (volume::check_vdb_structure). Throws bake::InvalidInput as that walk
// does ("bytes" or "grids[NAME]"), and "grids[NAME]" for a named grid the file lacks.
VdbMediumSize vdb_medium_size(std::span<const uint8_t> bytes, const std::string& density_grid,
                              const std::string& emission_grid);

struct LightmapJobSize {
  std::vector<uint64_t> lightmap_texels;  // per lightmap: width × height
  uint64_t traced_triangles = 0;          // over the instances, each its mesh's triangles (an upper bound will do)
  // The triangles the tracer holds (a mesh it instances once, scene::instanced_mesh; the others once per instance)
  // and those rasterized (of the instances that bake); count_triangles sets them. 0: as traced.
  uint64_t held_triangles = 0, baked_triangles = 0;
  uint64_t instances = 0;
  uint64_t mesh_blob_bytes = 0;           // the meshes as uploaded (KILNMSH1), summed over meshes (not instances)
  uint64_t texture_blob_bytes = 0;        // the encoded textures
  uint64_t environment_blob_bytes = 0;    // the encoded environment image
  bool ao = false, directional = false, radiance = false, denoise = false, preview = true;
  bool seams = true;      // stitched (LightmapBakeInput::stitch_seams)
  bool streamed = false;  // the outputs go to a sink page by page (the daemon) rather than back with the result
  uint64_t probes = 0;    // light probes, at most (probe_volume.h: ProbeVolumeOptions::max_probes); 0: none
  std::vector<VdbMediumSize> vdb_media;  // the VDB media, in the order given (homogeneous media cost nothing)
};

// What a light probe holds at the bake's peak: its replica sums (1.8 KiB), its summary, position and lattice index,
// and its 29 values in probes.vdb's trees (leaf nodes of 8³ voxels, assumed at least an eighth full where probes
// cluster near geometry) and in the file's bytes, copied twice as they are encoded.
inline constexpr uint64_t kProbeBytes = 4096;
// The probe placement's world-space copy of each traced triangle (three points).
inline constexpr uint64_t kProbePlacementBytesPerTriangle = 72;

// The seams of one lightmap while it is written, the larger of two stages: the search for them (seam_search_bytes_bound
// for its `triangles`: 636 bytes a triangle, whatever the geometry), then the stitcher (SeamStitcher::bytes_bound with
// the default caps: 362 bytes a texel of a large page, its lookups at most 48, its factors and a refactor 96 each, and
// 122 if every texel were along a seam) with the most seams those triangles can have held while it reads them.
// Images of at most kStitchedChannels channels are stitched (irradiance, radiance; AO has one).
inline constexpr int kStitchedChannels = 3;
uint64_t seam_bytes(uint64_t texels, uint64_t triangles);

struct LightmapMemoryEstimate {
  std::vector<uint64_t> lightmap_bytes;  // per lightmap, in the order given: what its texels cost
  uint64_t scene_bytes = 0;              // the meshes decoded, the tracer and edge_point_bytes
  uint64_t edge_point_bytes = 0;         // the sample points of triangles smaller than a texel, beyond 5 a texel
  uint64_t input_bytes = 0;              // the blobs and the decoded textures and environment
  uint64_t probe_bytes = 0;              // the light probes and their placement, when the job bakes any
  std::vector<uint64_t> medium_bytes;    // per VDB medium, in the order of LightmapJobSize::vdb_media
  uint64_t media_bytes = 0;              // their sum
  uint64_t total = 0;                    // the peak: the sum of the above and the largest set-up transient
  double bytes_per_texel = 0;            // of a lightmap, with the outputs asked for (untiled)
  double bytes_per_triangle = 0;         // traced
  int tile_size = 0;                     // 0: untiled
  uint64_t tiles = 0;                    // over all pages, when tiled
  double bytes_per_texel_in_flight = 0;  // the sampling state of a texel being sampled, set-up transient included
  double results_bytes_per_texel = 0;    // what a page keeps per texel once sampled (lightmap_results.h)
};

// The estimate of the bake untiled (tile_size 0) or in tiles of tile_size² texels.
// Sets job's traced, held and baked triangles and its instances from each mesh's triangles (an upper bound will do)
// and the instances (a mesh index out of range traces nothing), as the default tracer takes them.
void count_triangles(const std::vector<uint64_t>& mesh_triangles, const std::vector<scene::Instance>& instances,
                     LightmapJobSize& job);

LightmapMemoryEstimate estimate_memory(const LightmapJobSize& job, int tile_size = 0);

// The estimate of the bake as it will run under a memory limit (0: none): untiled when that fits the limit, else in
// the largest power-of-two tiles (at most the largest page's side, at least kMinTileSize) that fit, else in the
// smallest, whose estimate then exceeds the limit (the daemon refuses such a job; a bake run anyway takes it).
LightmapMemoryEstimate plan_memory(const LightmapJobSize& job, uint64_t limit_bytes);
inline constexpr int kMinTileSize = 16;

// "1.5 GiB" and the like, for messages.
std::string format_bytes(uint64_t bytes);

}  // namespace kiln::lightmap
