#include "bakers/lightmap/memory_estimate.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "bakers/bake/invalid_input.h"

#include "bakers/lightmap/leaks.h"
#include "bakers/lightmap/lightmap_image.h"
#include "bakers/lightmap/lightmap_results.h"
#include "bakers/lightmap/lightmap_state.h"
#include "bakers/lightmap/seams.h"
#include "bakers/lightmap/texels.h"
#include "bakers/math/rgb.h"
#include "bakers/scene/scene.h"
#include "bakers/scene/tracer.h"
#include "bakers/volume/grid_medium.h"
#include "bakers/volume/vdb_structure.h"

namespace kiln::lightmap {
namespace {

// The 2 × 2 stratified pattern gives a texel 4 points, and a triangle that covers part of a texel without holding
// one of its pattern points gives it one more (texels.cpp: Rasterizer::texel). Where triangles are larger than
// texels those are the texels on a chart's edges, so a fifth point a texel on average is a generous allowance; where
// they are smaller (a dense mesh on a small lightmap) nearly every triangle gives one: measured 1.06 and 1.1 a
// triangle (memory_estimate_test), counted as 1.5 (a triangle smaller than a texel overlaps one to four). A texel's
// points are therefore counted as 5 a texel, or 4 a texel and 1.5 a triangle where that is more.
constexpr double kSamplesPerTexel = 5;
constexpr double kPatternPointsPerTexel = 4;
constexpr double kEdgePointsPerTriangle = 1.5;

// The points beyond kSamplesPerTexel a texel that `triangles` smaller than texels may give `texels` texels.
double edge_points_beyond(double texels, double triangles) {
  return std::max(0.0, kEdgePointsPerTriangle * triangles - (kSamplesPerTexel - kPatternPointsPerTexel) * texels);
}

// The tracer per triangle at its peak, while Embree builds the BVH (RTC_BUILD_QUALITY_HIGH, spatial splits): measured
// on a 359 400-triangle sphere (memory_estimate_test.cpp), the tracer holds 224 bytes a triangle once built (BVH,
// float vertex and index buffers, its own records), and the bake peaked at 840 to 1 070 bytes a triangle in all over
// several runs, the builder's temporaries making most of the difference.
constexpr double kTracerPerTriangle = 1000;

// An instance the tracer holds as an Embree instance: its geometry, transform and records, and its share of the
// top-level BVH (an allowance; the level of 10,001 instances spends a few MB on them).
constexpr double kTracerPerInstance = 1024;

// What the bake keeps per traced triangle whatever the tracer holds (the instances' records of their triangles):
// 5 to 7 bytes measured with 10 to 640 instances of one mesh (memory_estimate_test), counted as 16.
constexpr double kPerTracedTriangle = 16;

// A tiled page bins its triangles by tile: 4 bytes a triangle in each tile it overlaps (about two, for triangles of a
// few texels near tile borders), and the bins' growth.
constexpr double kBinBytesPerTriangle = 16;

// A decoded mesh holds its vertices in double: about twice the bytes of the float blob; the bake holds the input,
// a copy it cleans and the cleaned scene while the scene is checked.
constexpr double kMeshCopies = 3 * 2;

// A texture decodes to an Rgb (three doubles) a texel; an 8-bit image compresses to about a byte a texel.
constexpr double kDecodedBytesPerEncodedByte = sizeof(Rgb);

// An output image: the float image and its encoded file (ZIP'd EXR, at most about the raw size), per channel.
constexpr double kOutputBytesPerChannel = 2 * sizeof(float);

double output_channels(const LightmapJobSize& job) {
  double c = 3 + 1 + 1;         // irradiance, validity, error
  if (job.preview) c += 3 + 1;  // the dilated irradiance again, and the PNG's bytes
  if (job.radiance) c += 3;
  if (job.ao) c += 3;
  if (job.directional) c += 12;
  // The denoiser: its output, and per texel the mean, variance and guides it reads (about 15 doubles).
  if (job.denoise) c += 3 + 15 * sizeof(double) / kOutputBytesPerChannel;
  return c;
}

// A majorant cell is one float (majorant_grid.h).
constexpr uint64_t kMajorantBytesPerCell = sizeof(float);

uint64_t medium_bytes(const VdbMediumSize& m) {
  return m.file_bytes + m.tree_bytes + kMajorantBytesPerCell * m.majorant_cells;
}

const volume::VdbGridStructure& named_grid(const volume::VdbStructure& s, const std::string& name) {
  std::string names;
  for (const volume::VdbGridStructure& g : s.grids) {
    if (g.name == name) return g;
    names += (names.empty() ? "'" : ", '") + g.name + "'";
  }
  throw bake::InvalidInput("grids[" + name + "]", "no such grid; the file holds " + (names.empty() ? "none" : names));
}

}  // namespace

VdbMediumSize vdb_medium_size(std::span<const uint8_t> bytes, const std::string& density_grid,
                              const std::string& emission_grid) {
  const volume::VdbStructure s = volume::check_vdb_structure(bytes);
  const volume::VdbGridStructure& density = named_grid(s, density_grid);
  if (!emission_grid.empty()) named_grid(s, emission_grid);
  VdbMediumSize m;
  m.file_bytes = bytes.size();
  // OpenVDB's stream reader reads every grid of the file before read_vdb keeps the named ones (vdb_file.cpp).
  m.tree_bytes = static_cast<uint64_t>(s.tree_bytes);
  m.majorant_cells = volume::GridMedium::majorant_cells(density.stored_lo, density.stored_hi);
  return m;
}

void count_triangles(const std::vector<uint64_t>& mesh_triangles, const std::vector<scene::Instance>& instances,
                     LightmapJobSize& job) {
  const auto triangles = [&](int m) {
    return m >= 0 && static_cast<size_t>(m) < mesh_triangles.size() ? mesh_triangles[m] : uint64_t{0};
  };
  std::vector<size_t> uses(mesh_triangles.size(), 0);
  job.traced_triangles = job.held_triangles = job.baked_triangles = 0;
  for (const scene::Instance& inst : instances) {
    if (triangles(inst.mesh) == 0) continue;
    ++uses[inst.mesh];
    job.traced_triangles += triangles(inst.mesh);
    if (inst.bake) job.baked_triangles += triangles(inst.mesh);
  }
  job.instances = instances.size();
  for (size_t m = 0; m < mesh_triangles.size(); ++m) {
    const bool once = scene::instanced_mesh(scene::Instancing::shared, uses[m], mesh_triangles[m]);
    job.held_triangles += (once ? std::min<size_t>(uses[m], 1) : uses[m]) * mesh_triangles[m];
  }
}

uint64_t seam_bytes(uint64_t texels, uint64_t triangles) {
  const auto seams = static_cast<uint64_t>(kMostSeamsPerTriangle * static_cast<double>(triangles));
  return std::max<uint64_t>(seam_search_bytes_bound(triangles),
                            SeamStitcher::bytes_bound(texels, kStitchedChannels, seams));
}

LightmapMemoryEstimate estimate_memory(const LightmapJobSize& job, int tile_size) {
  LightmapMemoryEstimate e;
  e.tile_size = tile_size;
  // With light tracing's sums and terms when untiled: the plan may trace light, which the spec does not say.
  const BakeStateBytes state = lightmap_state_bytes(job.ao, job.directional, /*traced=*/tile_size == 0);
  const double per_sample = sizeof(TexelSample);
  const double per_texel_held =
      sizeof(uint32_t) + LightmapImage::kBytesPerTexel + state.per_texel + kSamplesPerTexel * per_sample;
  const double per_texel_outputs = output_channels(job) * kOutputBytesPerChannel;
  e.results_bytes_per_texel = static_cast<double>(LightmapResults::bytes_per_texel(result_channels(job)));
  // The set-up's transient for one lightmap (or tile) at a time: the fragments, or the leak results (of the samples
  // probed: at most all, each with its index) and the samples kept.
  const double per_point_transient =
      std::max<double>(raster_bytes_per_fragment(), sizeof(LeakResult) + sizeof(uint32_t) + sizeof(uint8_t));
  const double per_texel_transient = kSamplesPerTexel * per_point_transient;
  e.bytes_per_texel_in_flight = per_texel_held + per_texel_transient;
  uint64_t largest = 0, smallest = job.lightmap_texels.empty() ? 0 : job.lightmap_texels.front(), all = 0;
  for (uint64_t texels : job.lightmap_texels) {
    largest = std::max(largest, texels);
    smallest = std::min(smallest, texels);
    all += texels;
  }
  // Tiled: the largest tile of any page is in flight.
  const uint64_t side = static_cast<uint64_t>(std::max(tile_size, 0));
  uint64_t tile_texels = 0;
  for (uint64_t texels : job.lightmap_texels) {
    if (side == 0) break;
    const auto page_side = static_cast<uint64_t>(std::ceil(std::sqrt(static_cast<double>(texels))));
    const uint64_t per_side = (page_side + side - 1) / side;
    e.tiles += per_side * per_side;
    tile_texels = std::max(tile_texels, std::min(texels, side * side));
  }
  // The tracer holds its triangles once per instanced mesh; the rasterizer, the bins and the seam search see the
  // baking instances'.
  const auto or_traced = [&](uint64_t n) { return n > 0 ? n : job.traced_triangles; };
  // One page's results while it is written, with its seams (of at most every baking triangle), and the outputs
  // held: one page's when they stream, every page's otherwise (counted per lightmap below when untiled).
  const double page_bytes =
      (e.results_bytes_per_texel + (job.streamed ? per_texel_outputs : 0.0)) * static_cast<double>(largest) +
      (job.seams ? static_cast<double>(seam_bytes(largest, or_traced(job.baked_triangles))) : 0.0);
  const bool all_outputs_here = !job.streamed && tile_size > 0;
  const uint64_t outputs_held =
      static_cast<uint64_t>(all_outputs_here ? per_texel_outputs * static_cast<double>(all) : 0.0);
  // While a lightmap is rasterized, each covering triangle also has a world-space copy.
  e.bytes_per_triangle = kTracerPerTriangle + static_cast<double>(raster_bytes_per_triangle());
  double triangle_bytes = e.bytes_per_triangle;
  if (tile_size > 0) triangle_bytes += kBinBytesPerTriangle;
  // The sample points of triangles smaller than a texel, beyond those counted per texel, with their transient: all
  // the baking triangles in the texels held (every lightmap's untiled, the smallest of which may hold them all; the
  // largest tile when tiled, a smaller one holding fewer pattern points).
  const double edge_points = edge_points_beyond(static_cast<double>(tile_size > 0 ? tile_texels : smallest),
                                                static_cast<double>(or_traced(job.baked_triangles)));
  e.edge_point_bytes = static_cast<uint64_t>(edge_points * (per_sample + per_point_transient));
  e.scene_bytes = e.edge_point_bytes +
                  static_cast<uint64_t>(kTracerPerTriangle * static_cast<double>(or_traced(job.held_triangles)) +
                                        kTracerPerInstance * static_cast<double>(job.instances) +
                                        kPerTracedTriangle * static_cast<double>(job.traced_triangles) +
                                        (triangle_bytes - kTracerPerTriangle) *
                                            static_cast<double>(or_traced(job.baked_triangles)) +
                                        kMeshCopies * static_cast<double>(job.mesh_blob_bytes));
  const double encoded = static_cast<double>(job.texture_blob_bytes + job.environment_blob_bytes);
  e.input_bytes =
      static_cast<uint64_t>(static_cast<double>(job.mesh_blob_bytes) + encoded + kDecodedBytesPerEncodedByte * encoded);
  if (job.probes > 0) e.probe_bytes = job.probes * kProbeBytes + job.traced_triangles * kProbePlacementBytesPerTriangle;
  for (const VdbMediumSize& m : job.vdb_media) {
    e.medium_bytes.push_back(medium_bytes(m));
    e.media_bytes += e.medium_bytes.back();
  }
  e.total =
      e.scene_bytes + e.input_bytes + e.probe_bytes + e.media_bytes + static_cast<uint64_t>(page_bytes) + outputs_held;
  if (tile_size == 0) {
    e.bytes_per_texel = per_texel_held + (job.streamed ? 0.0 : per_texel_outputs);
    for (uint64_t texels : job.lightmap_texels) {
      e.lightmap_bytes.push_back(static_cast<uint64_t>(e.bytes_per_texel * static_cast<double>(texels)));
    }
    e.total += static_cast<uint64_t>(per_texel_transient * static_cast<double>(largest));
    for (uint64_t b : e.lightmap_bytes) e.total += b;
    return e;
  }
  // Tiled: one tile's state in flight (and its set-up transient).
  e.bytes_per_texel = e.bytes_per_texel_in_flight;
  for (uint64_t texels : job.lightmap_texels) {
    // What a page costs while it bakes: a tile in flight and the page's results.
    e.lightmap_bytes.push_back(static_cast<uint64_t>(e.bytes_per_texel_in_flight *
                                                         static_cast<double>(std::min(texels, tile_texels)) +
                                                     e.results_bytes_per_texel * static_cast<double>(texels)));
  }
  e.total += static_cast<uint64_t>(e.bytes_per_texel_in_flight * static_cast<double>(tile_texels));
  return e;
}

LightmapMemoryEstimate plan_memory(const LightmapJobSize& job, uint64_t limit_bytes) {
  LightmapMemoryEstimate whole = estimate_memory(job, 0);
  if (limit_bytes == 0 || whole.total <= limit_bytes) return whole;
  uint64_t largest = 0;
  for (uint64_t texels : job.lightmap_texels) largest = std::max(largest, texels);
  const auto page_side = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(largest))));
  int side = kMinTileSize;
  while (side < page_side && side < 16384) side *= 2;
  for (; side >= kMinTileSize; side /= 2) {
    LightmapMemoryEstimate tiled = estimate_memory(job, side);
    if (tiled.total <= limit_bytes || side == kMinTileSize) return tiled;
  }
  return estimate_memory(job, kMinTileSize);
}

std::string format_bytes(uint64_t bytes) {
  char buf[64];
  const double b = static_cast<double>(bytes);
  if (b >= 1024.0 * 1024 * 1024) {
    std::snprintf(buf, sizeof buf, "%.2f GiB", b / (1024.0 * 1024 * 1024));
  } else if (b >= 1024.0 * 1024) {
    std::snprintf(buf, sizeof buf, "%.1f MiB", b / (1024.0 * 1024));
  } else {
    std::snprintf(buf, sizeof buf, "%llu bytes", static_cast<unsigned long long>(bytes));
  }
  return buf;
}

}  // namespace kiln::lightmap
