#include "bakers/uvgen/mesh_charts.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <queue>
#include <tuple>

#include "bakers/math/constants.h"

namespace kiln::uvgen {
namespace {

// The scene check's test for a triangle flat at float precision (scene_check.cpp's kFlatRatio): such triangles are
// dropped from the bake, so they get no chart.
constexpr double kFlatRatio = 0x1.0p-20;
// Normals at a shared position closer than this (cosine of ~1.1°) are one smooth normal written twice, not a hard edge.
constexpr double kSameNormal = 0.9998;
// Texture UVs closer than this at a shared position are the same UV written twice, not a seam.
constexpr double kSameUv = 1e-6;

std::array<uint64_t, 3> position_key(const Vec3& p) {
  std::array<uint64_t, 3> k{};
  const double c[3] = {p.x + 0.0, p.y + 0.0, p.z + 0.0};  // + 0.0 makes −0 into +0
  for (int i = 0; i < 3; ++i) std::memcpy(&k[i], &c[i], sizeof(double));
  return k;
}

bool usable_normal(const Vec3& n) { return is_finite(n) && dot(n, n) > 0; }

struct EdgeEntry {
  uint32_t a, b;  // welded vertices, a < b
  uint32_t t;
  int e;
  bool forward;  // the triangle runs a → b
};

}  // namespace

bool chartable(const Vec3& p0, const Vec3& p1, const Vec3& p2, Vec3* normal, double* area) {
  if (!is_finite(p0) || !is_finite(p1) || !is_finite(p2)) return false;
  const Vec3 n = cross(p1 - p0, p2 - p0);
  const double l2 = std::max({dot(p1 - p0, p1 - p0), dot(p2 - p1, p2 - p1), dot(p0 - p2, p0 - p2)});
  const double len = length(n);
  if (!(len > kFlatRatio * l2) || !std::isfinite(len)) return false;
  if (normal) *normal = n / len;
  if (area) *area = 0.5 * len;
  return true;
}

MeshAdjacency::MeshAdjacency(const scene::Mesh& mesh, const ChartOptions& options) : mesh_(mesh) {
  const size_t nv = mesh.positions.size();
  const size_t nt = mesh.indices.size() / 3;
  // Weld: vertices with bitwise-equal positions share an id, numbered in order of first appearance.
  std::vector<uint32_t> order(nv);
  std::iota(order.begin(), order.end(), 0u);
  std::vector<std::array<uint64_t, 3>> keys(nv);
  for (size_t v = 0; v < nv; ++v) keys[v] = position_key(mesh.positions[v]);
  std::stable_sort(order.begin(), order.end(), [&](uint32_t x, uint32_t y) { return keys[x] < keys[y]; });
  welded_.assign(nv, 0);
  for (size_t i = 0; i < nv; ++i) {
    if (i > 0 && keys[order[i]] == keys[order[i - 1]]) {
      welded_[order[i]] = welded_[order[i - 1]];
    } else {
      welded_[order[i]] = static_cast<uint32_t>(welded_count_++);
    }
  }

  usable_.assign(nt, 0);
  normal_.assign(nt, Vec3{});
  area_.assign(nt, 0);
  neighbour_.assign(nt, {-1, -1, -1});
  for (size_t t = 0; t < nt; ++t) {
    const uint32_t* i = &mesh.indices[3 * t];
    if (i[0] >= nv || i[1] >= nv || i[2] >= nv) continue;
    if (!chartable(mesh.positions[i[0]], mesh.positions[i[1]], mesh.positions[i[2]], &normal_[t], &area_[t])) continue;
    usable_[t] = 1;
  }

  std::vector<EdgeEntry> edges;
  edges.reserve(3 * nt);
  for (uint32_t t = 0; t < nt; ++t) {
    if (!usable_[t]) continue;
    for (int e = 0; e < 3; ++e) {
      const uint32_t a = welded(t, e), b = welded(t, (e + 1) % 3);
      if (a == b) continue;  // cannot happen for a usable triangle, but an edge of one vertex joins nothing
      edges.push_back({std::min(a, b), std::max(a, b), t, e, a < b});
    }
  }
  std::sort(edges.begin(), edges.end(), [](const EdgeEntry& x, const EdgeEntry& y) {
    return std::tie(x.a, x.b, x.t, x.e) < std::tie(y.a, y.b, y.t, y.e);
  });
  const bool normals = mesh.normals.size() == nv, uvs = mesh.uv.size() == nv;
  const double cos_hard = std::cos(options.hard_angle_degrees * kPi / 180);
  // Corner c of t and the corner of u at the same welded vertex differ in the mesh's own vertex data.
  auto split_at = [&](uint32_t t, int c, uint32_t u, int d) {
    const uint32_t vt = mesh.indices[3 * t + c], vu = mesh.indices[3 * u + d];
    if (vt == vu) return false;
    if (normals && usable_normal(mesh.normals[vt]) && usable_normal(mesh.normals[vu]) &&
        dot(normalize(mesh.normals[vt]), normalize(mesh.normals[vu])) < kSameNormal)
      return true;
    if (uvs && options.split_at_texture_seams) {
      const Point2 &x = mesh.uv[vt], &y = mesh.uv[vu];
      if (!(std::fabs(x.x - y.x) <= kSameUv && std::fabs(x.y - y.y) <= kSameUv)) return true;
    }
    return false;
  };
  for (size_t i = 0; i < edges.size();) {
    size_t j = i;
    while (j < edges.size() && edges[j].a == edges[i].a && edges[j].b == edges[i].b) ++j;
    // Two triangles running the edge in opposite directions are neighbours unless the edge is cut. Where more meet
    // (a non-manifold edge: a fin, a double-sided sheet), each is paired with the opposite-running one whose normal is
    // closest to its own, in order, so that each side of a double-sided sheet is a surface of its own.
    std::vector<uint8_t> paired(j - i, 0);
    for (size_t a = i; a < j; ++a) {
      if (paired[a - i]) continue;
      size_t best = j;
      for (size_t b = a + 1; b < j; ++b) {
        if (paired[b - i] || edges[b].forward == edges[a].forward || edges[b].t == edges[a].t) continue;
        if (best == j ||
            dot(normal_[edges[a].t], normal_[edges[b].t]) > dot(normal_[edges[a].t], normal_[edges[best].t]))
          best = b;
      }
      if (best == j) continue;
      paired[a - i] = paired[best - i] = 1;
      const EdgeEntry &x = edges[a], &y = edges[best];
      // x runs p → q over its corners e, e+1; y runs q → p, so y's corner f+1 is at p and f at q.
      const bool cut = dot(normal_[x.t], normal_[y.t]) < cos_hard || split_at(x.t, x.e, y.t, (y.e + 1) % 3) ||
                       split_at(x.t, (x.e + 1) % 3, y.t, y.e);
      if (!cut) {
        neighbour_[x.t][x.e] = y.t;
        neighbour_[y.t][y.e] = x.t;
      }
    }
    i = j;
  }
}

std::vector<Chart> grow_charts(const MeshAdjacency& adj, const ChartOptions& options) {
  const size_t nt = adj.triangle_count();
  std::vector<uint32_t> seeds;
  for (uint32_t t = 0; t < nt; ++t)
    if (adj.usable(t)) seeds.push_back(t);
  std::stable_sort(seeds.begin(), seeds.end(), [&](uint32_t a, uint32_t b) { return adj.area(a) > adj.area(b); });
  const double cos_max = std::cos(options.max_normal_deviation_degrees * kPi / 180);
  std::vector<int64_t> chart_of(nt, -1);
  std::vector<Chart> charts;
  using Candidate = std::pair<double, uint32_t>;  // (cost, triangle): the smallest first
  for (uint32_t seed : seeds) {
    if (chart_of[seed] >= 0) continue;
    const int64_t id = static_cast<int64_t>(charts.size());
    Chart chart{seed};
    chart_of[seed] = id;
    Vec3 sum = adj.normal(seed) * adj.area(seed);
    std::priority_queue<Candidate, std::vector<Candidate>, std::greater<>> queue;
    auto push_neighbours = [&](uint32_t t) {
      const Vec3 mean = normalize(sum);
      for (int e = 0; e < 3; ++e) {
        const int64_t u = adj.neighbour(t, e);
        if (u >= 0 && chart_of[u] < 0)
          queue.push({1 - dot(adj.normal(static_cast<uint32_t>(u)), mean), static_cast<uint32_t>(u)});
      }
    };
    push_neighbours(seed);
    while (!queue.empty()) {
      const uint32_t t = queue.top().second;
      queue.pop();
      if (chart_of[t] >= 0) continue;
      // The mean normal has moved since the candidate was queued: judge it against the chart as it is now.
      if (dot(adj.normal(t), normalize(sum)) < cos_max) continue;
      chart_of[t] = id;
      chart.push_back(t);
      sum += adj.normal(t) * adj.area(t);
      push_neighbours(t);
    }
    std::sort(chart.begin(), chart.end());
    charts.push_back(std::move(chart));
  }
  return charts;
}

std::vector<Chart> connected_pieces(const MeshAdjacency& adj, const Chart& triangles) {
  std::vector<uint32_t> sorted = triangles;
  std::sort(sorted.begin(), sorted.end());
  auto member = [&](int64_t t) { return t >= 0 && std::binary_search(sorted.begin(), sorted.end(), t); };
  std::vector<uint8_t> seen(sorted.size(), 0);
  auto index_of = [&](uint32_t t) {
    return static_cast<size_t>(std::lower_bound(sorted.begin(), sorted.end(), t) - sorted.begin());
  };
  std::vector<Chart> pieces;
  for (size_t i = 0; i < sorted.size(); ++i) {
    if (seen[i]) continue;
    Chart piece;
    std::vector<uint32_t> stack{sorted[i]};
    seen[i] = 1;
    while (!stack.empty()) {
      const uint32_t t = stack.back();
      stack.pop_back();
      piece.push_back(t);
      for (int e = 0; e < 3; ++e) {
        const int64_t u = adj.neighbour(t, e);
        if (!member(u)) continue;
        const size_t k = index_of(static_cast<uint32_t>(u));
        if (seen[k]) continue;
        seen[k] = 1;
        stack.push_back(static_cast<uint32_t>(u));
      }
    }
    std::sort(piece.begin(), piece.end());
    pieces.push_back(std::move(piece));
  }
  return pieces;
}

std::vector<Chart> split_chart(const MeshAdjacency& adj, const Chart& chart) {
  if (chart.size() < 2) return {chart};
  const scene::Mesh& mesh = adj.mesh();
  std::vector<Vec3> centroid(chart.size());
  Vec3 lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
  for (size_t i = 0; i < chart.size(); ++i) {
    const uint32_t* v = &mesh.indices[3 * chart[i]];
    centroid[i] = (mesh.positions[v[0]] + mesh.positions[v[1]] + mesh.positions[v[2]]) / 3.0;
    lo = {std::min(lo.x, centroid[i].x), std::min(lo.y, centroid[i].y), std::min(lo.z, centroid[i].z)};
    hi = {std::max(hi.x, centroid[i].x), std::max(hi.y, centroid[i].y), std::max(hi.z, centroid[i].z)};
  }
  const Vec3 extent = hi - lo;
  const int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
  auto coordinate = [&](size_t i) { return axis == 0 ? centroid[i].x : (axis == 1 ? centroid[i].y : centroid[i].z); };
  std::vector<size_t> order(chart.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return std::make_pair(coordinate(a), chart[a]) < std::make_pair(coordinate(b), chart[b]);
  });
  Chart first, second;
  for (size_t k = 0; k < order.size(); ++k) (k < order.size() / 2 ? first : second).push_back(chart[order[k]]);
  std::vector<Chart> out;
  for (const Chart* half : {&first, &second}) {
    for (Chart& piece : connected_pieces(adj, *half)) out.push_back(std::move(piece));
  }
  return out;
}

}  // namespace kiln::uvgen
