// The denoiser's guides (denoise.h) for one lightmap, from its bake's state: per valid texel the weight-averaged world
// position and texel size of its sample points (where leak handling left them), the normalised weight-averaged
// shading normal of their receivers, and its chart.
//
// Charts: the triangles of one instance connected through shared edges in lightmap-UV space, by union-find. Two
// triangles share an edge when both of its end points have equal lightmap UVs, compared by value (meshes split
// vertices at hard edges and UV seams alike; a split that keeps the UV is no seam in the lightmap). Instances are
// charts of their own even when they share a mesh. A texel takes the chart of its heaviest sample point.
#pragma once

#include <cstdint>
#include <unordered_map>
#include <vector>

#include "bakers/lightmap/denoise.h"
#include "bakers/lightmap/lightmap_state.h"
#include "bakers/scene/scene.h"

namespace kiln::lightmap {

// The UV chart of every triangle of `mesh`, numbered 0, 1, … in order of each chart's first triangle. A triangle
// with an index out of range, or a UV that is not finite, shares no edge (it is a chart of its own).
std::vector<uint32_t> uv_charts(const scene::Mesh& mesh);

// The charts of the texels of one page, numbered densely in order of first appearance: shared by the page's tiles
// (a tiled bake makes the guides a tile at a time), so that a chart has one number over the whole page.
class ChartIds {
 public:
  explicit ChartIds(const scene::Scene& scene) : scene_(scene) {}
  // The chart of a sample point's triangle.
  uint32_t of(const TriangleRef& triangle);

 private:
  const scene::Scene& scene_;
  std::unordered_map<uint32_t, std::vector<uint32_t>> mesh_charts_;  // uv_charts per mesh
  std::unordered_map<uint64_t, uint32_t> dense_;                      // (instance, chart of its mesh) → number
};

// The guides of `m`, whose texels were rasterized from `scene` (the checked scene the bake traced), with the texel
// validity of m.image; charts numbered by `charts` (which must be of the same scene).
TexelGuides texel_guides(const LightmapState& m, const scene::Scene& scene);
TexelGuides texel_guides(const LightmapState& m, const scene::Scene& scene, ChartIds& charts);
// The same from the texels alone, with their validity after leak handling (LightmapTexels::validity), for a tile
// whose state was never made (it was not sampled).
TexelGuides texel_guides(const LightmapTexels& texels, const std::vector<uint8_t>& validity, ChartIds& charts);

}  // namespace kiln::lightmap
