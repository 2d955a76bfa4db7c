#include "bakers/uvgen/chart_flatten.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_parameterization/LSCM_parameterizer_3.h>
#include <CGAL/Surface_mesh_parameterization/Two_vertices_parameterizer_3.h>
#include <CGAL/Surface_mesh_parameterization/parameterize.h>

#include "bakers/uvgen/uv_quality.h"

namespace kiln::uvgen {
namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using SurfaceMesh = CGAL::Surface_mesh<Kernel::Point_3>;
using VertexIndex = SurfaceMesh::Vertex_index;
namespace SMP = CGAL::Surface_mesh_parameterization;

std::array<Vec3, 3> corners(const scene::Mesh& mesh, uint32_t t) {
  const uint32_t* i = &mesh.indices[3 * t];
  return {mesh.positions[i[0]], mesh.positions[i[1]], mesh.positions[i[2]]};
}

// Whether two of the chart's triangles overlap in UV (a border that crossed itself), by the scene check's test on the
// chart alone, its UVs brought into [0, 1]² with one scale.
bool overlaps_itself(const MeshAdjacency& adj, const FlatChart& flat) {
  double x0 = INFINITY, y0 = INFINITY, extent = 0;
  for (const auto& q : flat.uv)
    for (const Point2& p : q) x0 = std::min(x0, p.x), y0 = std::min(y0, p.y);
  for (const auto& q : flat.uv)
    for (const Point2& p : q) extent = std::max({extent, p.x - x0, p.y - y0});
  if (!(extent > 0)) return true;
  scene::Mesh m;
  for (size_t k = 0; k < flat.triangles.size(); ++k) {
    const std::array<Vec3, 3> p = corners(adj.mesh(), flat.triangles[k]);
    for (int c = 0; c < 3; ++c) {
      m.indices.push_back(static_cast<uint32_t>(m.positions.size()));
      m.positions.push_back(p[c]);
      m.lightmap_uv.push_back({std::clamp((flat.uv[k][c].x - x0) / extent, 0.0, 1.0),
                               std::clamp((flat.uv[k][c].y - y0) / extent, 0.0, 1.0)});
    }
  }
  int64_t count = 0;
  overlapping_uv_triangles(m, 0, count);
  return count > 0;
}

// Checks the flattened chart and scales it to the chart's surface area; false if a triangle is not counter-clockwise
// (after mirroring the whole chart, when every triangle came out clockwise), the stretch is over the bound or the
// chart overlaps itself.
bool finish(const MeshAdjacency& adj, FlatChart& flat, const FlattenOptions& options) {
  int positive = 0, negative = 0;
  for (const auto& q : flat.uv) {
    for (const Point2& p : q)
      if (!std::isfinite(p.x) || !std::isfinite(p.y)) return false;
    const double a = (q[1].x - q[0].x) * (q[2].y - q[0].y) - (q[2].x - q[0].x) * (q[1].y - q[0].y);
    if (a > 0) ++positive;
    if (a < 0) ++negative;
  }
  const int n = static_cast<int>(flat.uv.size());
  if (negative == n) {
    for (auto& q : flat.uv)
      for (Point2& p : q) p.x = -p.x;
  } else if (positive != n) {
    return false;
  }
  DistortionSums sums;
  for (size_t k = 0; k < flat.triangles.size(); ++k) sums.add(corners(adj.mesh(), flat.triangles[k]), flat.uv[k]);
  if (sums.triangles() != n) return false;  // a triangle too thin in UV to measure
  const double scale = std::sqrt(sums.surface_area() / sums.uv_area());
  if (!std::isfinite(scale) || !(scale > 0)) return false;
  for (auto& q : flat.uv)
    for (Point2& p : q) p = {p.x * scale, p.y * scale};
  flat.l2_stretch = sums.l2_stretch();
  flat.mean_angle_error_degrees = sums.mean_angle_error_degrees();
  return flat.l2_stretch <= options.max_l2_stretch && !overlaps_itself(adj, flat);
}

FlatChart single(const MeshAdjacency& adj, uint32_t t) {
  const std::array<Vec3, 3> p = corners(adj.mesh(), t);
  const Vec3 e1 = p[1] - p[0], e2 = p[2] - p[0];
  const double l1 = length(e1);
  FlatChart flat;
  flat.triangles = {t};
  flat.uv = {{Point2{0, 0}, Point2{l1, 0}, Point2{dot(e2, e1) / l1, length(cross(e1, e2)) / l1}}};
  flat.method = FlattenMethod::single;
  return flat;
}

// LSCM through CGAL on the chart as a Surface_mesh of its welded vertices.
bool lscm(const MeshAdjacency& adj, FlatChart& flat) {
  SurfaceMesh sm;
  std::unordered_map<uint32_t, VertexIndex> local;
  std::vector<std::array<VertexIndex, 3>> faces;
  for (uint32_t t : flat.triangles) {
    std::array<VertexIndex, 3> f;
    for (int c = 0; c < 3; ++c) {
      const uint32_t w = adj.welded(t, c);
      auto it = local.find(w);
      if (it == local.end()) {
        const Vec3& p = adj.mesh().positions[adj.mesh().indices[3 * t + c]];
        it = local.emplace(w, sm.add_vertex(Kernel::Point_3(p.x, p.y, p.z))).first;
      }
      f[c] = it->second;
    }
    // A face CGAL cannot add (a non-manifold vertex or edge within the chart) leaves it to the projection.
    if (sm.add_face(f[0], f[1], f[2]) == SurfaceMesh::null_face()) return false;
    faces.push_back(f);
  }
  SurfaceMesh::Halfedge_index border = SurfaceMesh::null_halfedge();
  for (SurfaceMesh::Halfedge_index h : sm.halfedges()) {
    if (sm.is_border(h)) {
      border = h;
      break;
    }
  }
  if (border == SurfaceMesh::null_halfedge()) return false;  // closed: no free border to pin
  auto uv = sm.add_property_map<VertexIndex, Kernel::Point_2>("v:kiln_uv", Kernel::Point_2(NAN, NAN)).first;
  using Parameterizer = SMP::LSCM_parameterizer_3<SurfaceMesh, SMP::Two_vertices_parameterizer_3<SurfaceMesh>>;
  try {
    if (SMP::parameterize(sm, Parameterizer(), border, uv) != SMP::OK) return false;
  } catch (const std::exception&) {
    return false;
  }
  flat.uv.clear();
  for (const auto& f : faces) {
    std::array<Point2, 3> q;
    for (int c = 0; c < 3; ++c) q[c] = {uv[f[c]].x(), uv[f[c]].y()};
    flat.uv.push_back(q);
  }
  flat.method = FlattenMethod::lscm;
  return true;
}

void project(const MeshAdjacency& adj, FlatChart& flat) {
  Vec3 sum;
  for (uint32_t t : flat.triangles) sum += adj.normal(t) * adj.area(t);
  const Vec3 n = normalize(sum);
  // Any two axes across n, right-handed with it, so that a triangle facing n comes out counter-clockwise.
  const Vec3 helper = std::fabs(n.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  const Vec3 u = normalize(cross(helper, n)), v = cross(n, u);
  flat.uv.clear();
  for (uint32_t t : flat.triangles) {
    const std::array<Vec3, 3> p = corners(adj.mesh(), t);
    flat.uv.push_back(
        {Point2{dot(p[0], u), dot(p[0], v)}, Point2{dot(p[1], u), dot(p[1], v)}, Point2{dot(p[2], u), dot(p[2], v)}});
  }
  flat.method = FlattenMethod::projection;
}

}  // namespace

const char* to_string(FlattenMethod method) {
  switch (method) {
    case FlattenMethod::single:
      return "single";
    case FlattenMethod::lscm:
      return "lscm";
    case FlattenMethod::projection:
      return "projection";
  }
  return "?";
}

std::optional<FlatChart> flatten_chart(const MeshAdjacency& adj, const Chart& chart, const FlattenOptions& options) {
  if (chart.empty()) return std::nullopt;
  if (chart.size() == 1) {
    // Always usable: its layout is exact, whatever the bound (finish only measures it).
    FlatChart flat = single(adj, chart[0]);
    finish(adj, flat, options);
    return flat;
  }
  FlatChart flat;
  flat.triangles = chart;
  if (lscm(adj, flat) && finish(adj, flat, options)) return flat;
  project(adj, flat);
  if (finish(adj, flat, options)) return flat;
  return std::nullopt;
}

}  // namespace kiln::uvgen
