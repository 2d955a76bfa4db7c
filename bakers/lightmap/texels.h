// The texels of one lightmap: the triangles of every instance baking into it, rasterized in lightmap-UV space with
// conservative coverage into sample points on the surface (as Bakery and Unity's progressive lightmapper do), each
// with the fraction of its texel it stands for. The transport estimates irradiance at these points; texels without
// any are invalid and are filled by dilation (dilate.h).
//
// ## UV and texel conventions
// u grows to the right (columns), v grows downwards (rows): v = 0 is the top row, as in glTF (and scene::Texture) and
// as in the EXR files written from it (bakers/image/exr.h stores the top row first), so row y of the lightmap is row
// y of the image. Texel space is (s, t) = (u·W, v·H): texel (x, y) — column x, row y — is the unit square
// [x, x+1] × [y, y+1]; its centre is ((x + 0.5)/W, (y + 0.5)/H) in UV. UVs outside [0, 1] are not wrapped: the part
// of a triangle outside the lightmap is not baked (and counted in the report). An instance's
// lightmap_scale_offset {s_u, s_v, o_u, o_v} applies first: (u, v) → (s_u·u + o_u, s_v·v + o_v).
//
// ## Coverage and sample points
// A texel is covered by a triangle when the triangle clipped to the texel square (Sutherland–Hodgman) has an area
// above kMinCoverage (texel² units): any overlap counts, even when the texel centre is outside the triangle, so thin
// charts and chart edges are not lost; a triangle touching a texel only along an edge or at a corner (zero area)
// does not cover it. For each covered texel the triangle gives the points of a stratified k×k pattern of the texel
// (cell centres, k = samples_per_axis) that lie in the triangle, each with weight (clipped area)/(points inside);
// when no pattern point lies in it (a sliver), one point: the mean of the clipped polygon's vertices, a point of the
// covered region and so of both the triangle and the texel. (Not the triangle's point nearest the texel centre: that
// point can lie outside the texel when a thin triangle cuts a corner.)
// Weights are fractions of the texel's area: they sum to 1 over a texel its triangles cover entirely and to the
// covered fraction at chart edges; a sum above 1 means overlapping charts (counted in the report).
//
// ## World-space frame
// Positions are transformed by the instance's to_world. The geometric normal is the unit normal of the world
// triangle on its front side: (P1 − P0) × (P2 − P0), flipped when the instance transform mirrors (det < 0), as glTF
// defines the winding of mirrored nodes. Vertex normals transform by the inverse transpose (the same rule gives the
// same flip), are interpolated with the barycentrics and normalised; a mesh without usable normals gets the
// geometric normal.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "bakers/bake/stop.h"
#include "bakers/math/sampling.h"
#include "bakers/math/vec3.h"
#include "bakers/scene/ray_offset.h"
#include "bakers/scene/scene.h"

namespace kiln::lightmap {

// Coverage below this (in texel² units) is none: far below any coverage that matters (a 10⁻⁶ × 10⁻⁶ texel corner),
// far above the rounding of a polygon clip near the unit square (~10⁻¹⁶), so edge-only contacts read as zero.
inline constexpr double kMinCoverage = 1e-12;

struct TriangleRef {
  uint32_t instance = 0;  // into Scene::instances
  uint32_t mesh = 0;      // into Scene::meshes (that instance's mesh)
  uint32_t triangle = 0;  // into the mesh's triangles (indices[3·triangle .. 3·triangle + 2])
};

// One point at which a texel's irradiance is estimated.
struct TexelSample {
  Vec3 position;          // world space, on the triangle (leak handling may move it off, see leaks.h)
  Vec3 geometric_normal;  // world space, unit, the triangle's front side
  Vec3 shading_normal;    // world space, unit (the geometric normal where the mesh has no usable normals)
  Point2 barycentric;     // (b1, b2) of the original point on the triangle; b0 = 1 − b1 − b2; all in [0, 1]
  double weight = 0;      // fraction of the texel's area this point stands for
  TriangleRef triangle;
  float texel_world_size = 0;  // world length of a texel's edge on this triangle: √(world area / texel-space area)
  // The lift along the geometric normal that keeps rays leaving this point from finding its own triangle in the
  // float tracer (scene::self_intersection_offset of the triangle's world vertices rounded to float, as the tracer
  // holds them).
  float ray_offset = 0;
  // Leak handling moved this point off its triangle, or dropped another point of its texel: the texel's points no
  // longer stand for the surface the texel covers (light tracing leaves such texels to gathering, light_tracing.h).
  bool leak_fixed = false;

  // For scene::spawn_ray and friends.
  scene::SurfacePoint surface() const { return {position, geometric_normal, ray_offset}; }
};

struct RasterOptions {
  int width = 0, height = 0;  // lightmap resolution, [1, 16384] each
  int samples_per_axis = 2;   // k: the stratified pattern has k×k points per texel, [1, 16]
  // Optional, per mesh then per triangle: 0 leaves the triangle out (it is not counted as skipped), e.g.
  // scene::CheckedScene::triangles[m].bake, so that triangles the scene check marked "traced, not baked" (UVs outside
  // [0, 1]) are not baked. Null, or a mesh without an entry: every triangle.
  const std::vector<std::vector<uint8_t>>* bake_mask = nullptr;
  // Optional: rasterize only this window of the W×H map (a tile of a page): the result is window-sized, its texel
  // (0, 0) being texel (x0, y0) of the map. Width or height 0: the whole map.
  struct Window {
    int x0 = 0, y0 = 0, width = 0, height = 0;
  } window{};
  // Optional: only these triangles, by their index in the sequence of the map's instances' triangles (instances in
  // scene order, each its mesh's triangles in order), ascending: a tile's bin (TileBins), so that a tile does not
  // walk every triangle of its page. Null: every triangle.
  const std::vector<uint32_t>* triangles = nullptr;
};

// A page cut into square tiles of `tile_size` texels (the last row and column smaller), row-major, and per tile the
// triangles whose UV bounds overlap it and the UV area they cover in it (texels; overlapping charts count twice),
// for dividing a time limit among the tiles before any is rasterized.
struct TileBins {
  int width = 0, height = 0, tile_size = 0, tiles_x = 0, tiles_y = 0;
  std::vector<std::vector<uint32_t>> triangles;
  std::vector<double> coverage;

  size_t tile_count() const { return triangles.size(); }
  RasterOptions::Window window(size_t tile) const;
};

// Why a triangle (or all triangles of an instance) produced no texels.
enum class SkipReason : uint8_t {
  no_mesh,             // the instance refers to a mesh index that does not exist
  no_lightmap_uv,      // the mesh has no lightmap UVs, or not one per position
  index_out_of_range,  // an index is not below the number of positions (or the index count is not a multiple of 3)
  non_finite_vertex,   // a position or lightmap UV is NaN or infinite
  degenerate_uv,       // UV area at most kMinCoverage texels²: it covers no texel
  degenerate_world,    // zero area in world space (or a singular instance transform): no surface to light
};
inline constexpr int kSkipReasonCount = 6;
const char* to_string(SkipReason reason);

struct SkippedTriangle {
  TriangleRef triangle;  // for no_mesh and no_lightmap_uv: the instance, with triangle = 0 standing for all of them
  SkipReason reason;
};

struct RasterReport {
  size_t instances = 0;                            // instances baking into this lightmap
  size_t triangles = 0;                            // their triangles
  size_t rasterized = 0;                           // triangles that covered at least one texel
  size_t masked = 0;                               // left out by RasterOptions::bake_mask
  std::array<size_t, kSkipReasonCount> skipped{};  // triangles skipped, by SkipReason
  std::vector<SkippedTriangle> skipped_examples;   // the first kMaxSkippedExamples, in scene order
  size_t outside_unit_square = 0;                  // triangles with some UV outside [0, 1]: that part is not baked
  size_t unusable_normals = 0;    // triangles whose vertex normals were missing, non-finite or zero: normal = Ng
  size_t overlapping_texels = 0;  // texels whose weights sum above 1: charts overlap there
  static constexpr size_t kMaxSkippedExamples = 32;
  size_t skipped_total() const;
};

// The samples of a W×H lightmap, grouped by texel (row-major, top row first): the samples of texel i = y·W + x are
// samples[first[i] .. first[i + 1]), in scene order (instance, triangle, pattern point). Deterministic: the same scene
// and options give the same samples in the same order, whatever the number of threads.
struct LightmapTexels {
  int width = 0, height = 0;
  std::vector<uint32_t> first;  // W·H + 1 offsets into samples
  std::vector<TexelSample> samples;
  RasterReport report;

  size_t texel_count() const { return static_cast<size_t>(width) * height; }
  size_t index(int x, int y) const { return static_cast<size_t>(y) * width + x; }
  bool valid(size_t texel) const { return first[texel + 1] > first[texel]; }
  bool valid(int x, int y) const { return valid(index(x, y)); }
  std::span<const TexelSample> at(size_t texel) const {
    return {samples.data() + first[texel], samples.data() + first[texel + 1]};
  }
  std::span<const TexelSample> at(int x, int y) const { return at(index(x, y)); }
  // What the texels hold in memory: their offsets and samples.
  size_t bytes() const { return first.size() * sizeof(uint32_t) + samples.size() * sizeof(TexelSample); }
  // 1 for texels with samples, 0 for the others; W·H bytes, row-major.
  std::vector<uint8_t> validity() const;
  size_t valid_count() const;
  // Keeps the samples with keep[j] != 0 (keep has one entry per sample), preserving order; texels left without
  // samples become invalid.
  void retain(const std::vector<uint8_t>& keep);
};

// The distinct lightmap names (scene::resolved_lightmap_name) of the instances that bake (bake = true), in order of
// first appearance.
std::vector<std::string> lightmap_names(const scene::Scene& scene);

// Rasterizes every baking instance whose lightmap (scene::resolved_lightmap_name) is `name`. Bad geometry is skipped
// and reported, never fatal. Throws std::invalid_argument for options out of range (naming the field) or when the
// sample count would exceed 2³² − 1 (lower the resolution or samples_per_axis). Uses all cores (TBB). Polls `stop`
// every block of triangles and samples and throws what its check() throws.
LightmapTexels rasterize_lightmap(const scene::Scene& scene, const std::string& name, const RasterOptions& options,
                                  const bake::StopCheck& stop = {});
// The same into `out`, whose storage is reused (a tiled bake's tiles, one after another, without allocating and
// first touching every tile's samples anew).
void rasterize_lightmap_into(LightmapTexels& out, const scene::Scene& scene, const std::string& name,
                             const RasterOptions& options, const bake::StopCheck& stop = {});

// The tiles of lightmap `name` rasterized at options' size, tile_size texels on a side, [1, 16384]. Triangles
// without finite UVs or with indices out of range go to the first tile, where rasterization reports them. Throws
// std::invalid_argument when the triangles number more than 2^32 − 1. Polls `stop`.
TileBins bin_triangles(const scene::Scene& scene, const std::string& name, const RasterOptions& options, int tile_size,
                       const bake::StopCheck& stop = {});

// The transient memory of rasterize_lightmap beyond its result: each sample is first a compact fragment, and each
// triangle that covers a texel keeps its world-space vertices and normals until the
// samples are made.
size_t raster_bytes_per_fragment();
size_t raster_bytes_per_triangle();

}  // namespace kiln::lightmap
