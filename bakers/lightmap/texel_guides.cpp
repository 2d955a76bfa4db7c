#include "bakers/lightmap/texel_guides.h"

#include <algorithm>
#include <cmath>
#include <tuple>
#include <unordered_map>

namespace kiln::lightmap {
namespace {

// Union-find with path halving; the smaller index becomes the root, so roots do not depend on the order of unions.
class DisjointSets {
 public:
  explicit DisjointSets(size_t n) : parent_(n) {
    for (size_t i = 0; i < n; ++i) parent_[i] = static_cast<uint32_t>(i);
  }
  uint32_t find(uint32_t i) {
    while (parent_[i] != i) i = parent_[i] = parent_[parent_[i]];
    return i;
  }
  void unite(uint32_t a, uint32_t b) {
    a = find(a);
    b = find(b);
    if (a != b) parent_[std::max(a, b)] = std::min(a, b);
  }

 private:
  std::vector<uint32_t> parent_;
};

// A triangle's edge in UV space, its end points in a fixed order so that both triangles of the edge agree.
struct UvEdge {
  Point2 a, b;
  uint32_t triangle;
};

bool uv_less(const Point2& p, const Point2& q) { return std::tie(p.x, p.y) < std::tie(q.x, q.y); }
bool same_edge(const UvEdge& e, const UvEdge& f) {
  return e.a.x == f.a.x && e.a.y == f.a.y && e.b.x == f.b.x && e.b.y == f.b.y;
}

// The edges of every triangle whose indices are in range and whose UVs are finite (NaN would break the sort's order).
std::vector<UvEdge> uv_edges(const scene::Mesh& mesh) {
  const size_t triangles = mesh.indices.size() / 3, vertices = mesh.lightmap_uv.size();
  std::vector<UvEdge> edges;
  edges.reserve(3 * triangles);
  for (size_t t = 0; t < triangles; ++t) {
    const uint32_t* idx = &mesh.indices[3 * t];
    if (idx[0] >= vertices || idx[1] >= vertices || idx[2] >= vertices) continue;
    const Point2 uv[3] = {mesh.lightmap_uv[idx[0]], mesh.lightmap_uv[idx[1]], mesh.lightmap_uv[idx[2]]};
    if (!std::all_of(uv, uv + 3, [](const Point2& p) { return std::isfinite(p.x) && std::isfinite(p.y); })) continue;
    for (int k = 0; k < 3; ++k) {
      Point2 a = uv[k], b = uv[(k + 1) % 3];
      if (uv_less(b, a)) std::swap(a, b);
      edges.push_back({a, b, static_cast<uint32_t>(t)});
    }
  }
  return edges;
}

}  // namespace

std::vector<uint32_t> uv_charts(const scene::Mesh& mesh) {
  const size_t triangles = mesh.indices.size() / 3;
  std::vector<UvEdge> edges = uv_edges(mesh);
  std::sort(edges.begin(), edges.end(), [](const UvEdge& e, const UvEdge& f) {
    return std::tie(e.a.x, e.a.y, e.b.x, e.b.y, e.triangle) < std::tie(f.a.x, f.a.y, f.b.x, f.b.y, f.triangle);
  });
  DisjointSets sets(triangles);
  for (size_t i = 1; i < edges.size(); ++i) {
    if (same_edge(edges[i - 1], edges[i])) sets.unite(edges[i - 1].triangle, edges[i].triangle);
  }
  std::vector<uint32_t> chart(triangles);
  std::vector<uint32_t> number(triangles, UINT32_MAX);  // per root
  uint32_t next = 0;
  for (size_t t = 0; t < triangles; ++t) {
    uint32_t& n = number[sets.find(static_cast<uint32_t>(t))];
    if (n == UINT32_MAX) n = next++;
    chart[t] = n;
  }
  return chart;
}

uint32_t ChartIds::of(const TriangleRef& tri) {
  auto it = mesh_charts_.find(tri.mesh);
  if (it == mesh_charts_.end()) it = mesh_charts_.emplace(tri.mesh, uv_charts(scene_.meshes.at(tri.mesh))).first;
  const uint64_t key = (static_cast<uint64_t>(tri.instance) << 32) | it->second.at(tri.triangle);
  return dense_.emplace(key, static_cast<uint32_t>(dense_.size())).first->second;
}

TexelGuides texel_guides(const LightmapState& m, const scene::Scene& scene) {
  ChartIds charts(scene);
  return texel_guides(m, scene, charts);
}

TexelGuides texel_guides(const LightmapState& m, const scene::Scene&, ChartIds& chart_ids) {
  return texel_guides(m.texels, m.image.validity(), chart_ids);
}

TexelGuides texel_guides(const LightmapTexels& tx, const std::vector<uint8_t>& validity, ChartIds& chart_ids) {
  const size_t n = tx.texel_count();
  TexelGuides g;
  g.width = tx.width;
  g.height = tx.height;
  g.valid = validity;
  g.position.assign(n, Vec3{});
  g.normal.assign(n, Vec3{});
  g.texel_size.assign(n, 0.0);
  g.chart.assign(n, 0);
  // Numbered in sample order, every sample's (not only the valid texels'), as the page's first appearance.
  std::vector<uint32_t> charts(tx.samples.size());
  for (size_t j = 0; j < tx.samples.size(); ++j) charts[j] = chart_ids.of(tx.samples[j].triangle);
  for (size_t t = 0; t < n; ++t) {
    if (!g.valid[t]) continue;
    double w = 0, size = 0, heaviest = -1;
    Vec3 p, ns;
    for (uint32_t j = tx.first[t]; j < tx.first[t + 1]; ++j) {
      const double wj = tx.samples[j].weight;
      w += wj;
      const Receiver r = receiver_of(tx.samples[j]);
      p += r.surface.p * wj;
      ns += r.ns * wj;
      size += tx.samples[j].texel_world_size * wj;
      if (wj > heaviest) {
        heaviest = wj;
        g.chart[t] = charts[j];
        g.normal[t] = r.ns;  // kept where the normals cancel
      }
    }
    g.position[t] = p / w;
    g.texel_size[t] = size / w;
    const double len = length(ns);
    if (len > 0 && std::isfinite(len)) g.normal[t] = ns / len;
  }
  return g;
}

}  // namespace kiln::lightmap
