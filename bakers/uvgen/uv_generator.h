// Lightmap-UV generation for a mesh whose own lightmap UVs are missing or unusable: charts (mesh_charts.h), each
// flattened (chart_flatten.h), packed with padding at a texel density (chart_pack.h), and checked.
//
// 1. Charts by region growing; a chart that no flattening gets within the stretch bound is split (split_chart) and
//    its pieces flattened, down to single triangles, which always flatten exactly.
// 2. The charts are packed and the mesh's triangles tested for overlapping UVs (the scene check's test); the charts
//    holding an overlapping triangle (a chart whose border crossed itself) are split, flattened and packed again, for
//    up to `max_rounds` rounds, after which such charts are cut into single triangles. The result has no overlap.
// 3. The mesh is returned with `lightmap_uv` set: a vertex used by several charts is duplicated (the copies appended
//    after the mesh's own vertices, with its normal and texture UV), so the input's vertex indices and triangles
//    keep their meaning; triangles no chart holds (unusable, as the scene check drops them) keep their indices.
// Deterministic: the same mesh and options give the same bytes (the charts are flattened in parallel, each on its
// own, and collected in order).
#pragma once

#include <cstdint>
#include <string>

#include "bakers/bake/stop.h"
#include "bakers/scene/scene.h"
#include "bakers/uvgen/chart_flatten.h"
#include "bakers/uvgen/chart_pack.h"
#include "bakers/uvgen/mesh_charts.h"
#include "bakers/uvgen/uv_quality.h"

namespace kiln::uvgen {

// When a bake generates lightmap UVs: `automatic` for meshes whose own are unusable (unusable_lightmap_uvs), `always`
// for every mesh, `never` for none.
enum class GenerateUvs { automatic, always, never };
const char* to_string(GenerateUvs mode);

struct UvgenOptions {
  ChartOptions charts;
  FlattenOptions flatten;
  PackOptions pack;
  int max_rounds = 6;
};

struct UvgenStats {
  int charts = 0;
  int lscm_charts = 0, projection_charts = 0, single_charts = 0;
  int split_rounds = 0;  // rounds of splitting charts whose UVs overlapped
  PackedCharts pack;     // the square the charts were packed in
  UvQuality quality;     // of the generated UVs (overlaps: 0)
  int64_t vertices_added = 0;
  int64_t triangles_uncharted = 0;  // unusable triangles (no chart)
  double seconds = 0;
};

struct GeneratedUvs {
  scene::Mesh mesh;
  UvgenStats stats;
};

// Why the mesh's own lightmap UVs cannot be baked as they are, for people ("no lightmap UVs", "12 triangles' lightmap
// UVs leave [0, 1]", "340 pairs of triangles overlap in lightmap UV space"); empty when they can.
std::string unusable_lightmap_uvs(const scene::Mesh& mesh);

// Polls `stop` between stages and charts.
GeneratedUvs generate_lightmap_uvs(const scene::Mesh& mesh, const UvgenOptions& options,
                                   const bake::StopCheck& stop = {});

}  // namespace kiln::uvgen
