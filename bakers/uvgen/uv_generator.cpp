#include "bakers/uvgen/uv_generator.h"

#include <algorithm>
#include <chrono>
#include <optional>
#include <unordered_map>
#include <utility>

#include <tbb/parallel_for.h>

namespace kiln::uvgen {
namespace {

// Overlapping pairs listed per round: enough to find every chart that overlaps itself in one round on real meshes;
// the rest are found in the next round.
constexpr size_t kListedPairs = 100000;

// Flattens the charts, splitting the ones that do not flatten until every piece does; in a fixed order (a chart's
// pieces take its place), so that the result does not depend on the threads.
std::vector<FlatChart> flatten_all(const MeshAdjacency& adj, std::vector<Chart> pending, const FlattenOptions& options,
                                   const bake::StopCheck& stop) {
  std::vector<FlatChart> done;
  while (!pending.empty()) {
    stop.check();
    std::vector<std::optional<FlatChart>> flat(pending.size());
    tbb::parallel_for(size_t{0}, pending.size(), [&](size_t i) {
      if (!stop.requested()) flat[i] = flatten_chart(adj, pending[i], options);
    });
    stop.check();
    std::vector<Chart> next;
    for (size_t i = 0; i < pending.size(); ++i) {
      if (flat[i]) {
        done.push_back(std::move(*flat[i]));
      } else {
        for (Chart& piece : split_chart(adj, pending[i])) next.push_back(std::move(piece));
      }
    }
    pending = std::move(next);
  }
  return done;
}

// The mesh with the packed charts' UVs: the first chart to use a vertex keeps it, the others get copies.
scene::Mesh build_mesh(const scene::Mesh& in, const std::vector<FlatChart>& charts, int64_t& added) {
  scene::Mesh out = in;
  const size_t nv = in.positions.size();
  const bool normals = in.normals.size() == nv, uvs = in.uv.size() == nv;
  out.lightmap_uv.assign(nv, Point2{0, 0});
  std::vector<int64_t> owner(nv, -1);             // the chart that has the vertex itself
  std::unordered_map<uint64_t, uint32_t> copies;  // (vertex, chart) → the copy's index
  for (size_t c = 0; c < charts.size(); ++c) {
    for (size_t k = 0; k < charts[c].triangles.size(); ++k) {
      const uint32_t t = charts[c].triangles[k];
      for (int j = 0; j < 3; ++j) {
        const uint32_t v = in.indices[3 * t + j];
        uint32_t target = v;
        if (owner[v] < 0) {
          owner[v] = static_cast<int64_t>(c);
        } else if (owner[v] != static_cast<int64_t>(c)) {
          const uint64_t key = (static_cast<uint64_t>(v) << 32) | static_cast<uint64_t>(c);
          auto [it, fresh] = copies.emplace(key, static_cast<uint32_t>(out.positions.size()));
          if (fresh) {
            out.positions.push_back(in.positions[v]);
            if (normals) out.normals.push_back(in.normals[v]);
            if (uvs) out.uv.push_back(in.uv[v]);
            out.lightmap_uv.emplace_back();
          }
          target = it->second;
        }
        out.indices[3 * t + j] = target;
        out.lightmap_uv[target] = charts[c].uv[k][j];
      }
    }
  }
  added = static_cast<int64_t>(out.positions.size() - nv);
  return out;
}

}  // namespace

const char* to_string(GenerateUvs mode) {
  switch (mode) {
    case GenerateUvs::automatic:
      return "auto";
    case GenerateUvs::always:
      return "always";
    case GenerateUvs::never:
      return "never";
  }
  return "?";
}

std::string unusable_lightmap_uvs(const scene::Mesh& mesh) {
  if (mesh.lightmap_uv.empty()) return "no lightmap UVs";
  if (mesh.lightmap_uv.size() != mesh.positions.size()) {
    return "lightmap UVs for " + std::to_string(mesh.lightmap_uv.size()) + " of " +
           std::to_string(mesh.positions.size()) + " vertices";
  }
  const scene::CheckedScene checked = check_mesh_alone(mesh, 0);
  using scene::ProblemKind;
  if (const int64_t n = checked.report.count(ProblemKind::lightmap_uv_out_of_range); n > 0)
    return std::to_string(n) + " triangles' lightmap UVs leave [0, 1]";
  if (const int64_t n = checked.report.count(ProblemKind::overlapping_lightmap_uv); n > 0)
    return std::to_string(n) + " pairs of triangles overlap in lightmap UV space (mirrored or shared texture UVs)";
  return "";
}

GeneratedUvs generate_lightmap_uvs(const scene::Mesh& mesh, const UvgenOptions& options, const bake::StopCheck& stop) {
  const auto t0 = std::chrono::steady_clock::now();
  GeneratedUvs result;
  UvgenStats& stats = result.stats;
  const MeshAdjacency adj(mesh, options.charts);
  for (size_t t = 0; t < adj.triangle_count(); ++t)
    stats.triangles_uncharted += adj.usable(static_cast<uint32_t>(t)) ? 0 : 1;
  stop.check();
  std::vector<FlatChart> charts = flatten_all(adj, grow_charts(adj, options.charts), options.flatten, stop);
  for (int round = 0;; ++round) {
    std::vector<FlatChart> packed = charts;
    stats.pack = pack_charts(packed, options.pack, stop);
    result.mesh = build_mesh(mesh, packed, stats.vertices_added);
    stop.check();
    int64_t count = 0;
    const auto pairs = overlapping_uv_triangles(result.mesh, kListedPairs, count);
    if (count == 0) break;
    // The charts that hold an overlapping triangle: split (or, after max_rounds, cut into single triangles).
    std::vector<int64_t> chart_of(adj.triangle_count(), -1);
    for (size_t c = 0; c < charts.size(); ++c)
      for (uint32_t t : charts[c].triangles) chart_of[t] = static_cast<int64_t>(c);
    std::vector<uint8_t> bad(charts.size(), 0);
    for (const auto& [a, b] : pairs) {
      if (chart_of[a] >= 0) bad[chart_of[a]] = 1;
      if (chart_of[b] >= 0) bad[chart_of[b]] = 1;
    }
    std::vector<FlatChart> kept;
    std::vector<Chart> redo;
    for (size_t c = 0; c < charts.size(); ++c) {
      if (!bad[c] || charts[c].triangles.size() == 1) {
        kept.push_back(std::move(charts[c]));
      } else if (round + 1 >= options.max_rounds) {
        for (uint32_t t : charts[c].triangles) redo.push_back({t});
      } else {
        for (Chart& piece : split_chart(adj, charts[c].triangles)) redo.push_back(std::move(piece));
      }
    }
    // Only single-triangle charts overlap (a packing squeezed to one texel per chart): nothing left to split.
    if (redo.empty()) break;
    for (FlatChart& f : flatten_all(adj, std::move(redo), options.flatten, stop)) kept.push_back(std::move(f));
    charts = std::move(kept);
    stats.split_rounds = round + 1;
  }
  stats.charts = static_cast<int>(charts.size());
  for (const FlatChart& c : charts) {
    (c.method == FlattenMethod::lscm         ? stats.lscm_charts
     : c.method == FlattenMethod::projection ? stats.projection_charts
                                             : stats.single_charts)++;
  }
  stats.quality = measure_uv_quality(result.mesh);
  stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

}  // namespace kiln::uvgen
