#include "bakers/lightmap/leak_scope.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "bakers/math/constants.h"
#include "bakers/scene/transform_determinant.h"

namespace kiln::lightmap {
namespace {

// Meshes whose convexity test (every triangle against every vertex) would take more than this many plane tests are
// probed instead (~0.05 s of work: a 7,000-triangle rock).
constexpr double kMaxConvexTests = 5e7;

std::vector<uint8_t> used_vertices(const scene::Mesh& mesh) {
  std::vector<uint8_t> used(mesh.positions.size(), 0);
  for (uint32_t i : mesh.indices) used[i] = 1;
  return used;
}

struct Point2d {
  double x, y;
};

// Whether triangles a and b (counter-clockwise in 2D) overlap with a positive area: no edge of either separates
// them by more than -tol (touching along an edge or at a vertex is not overlapping).
bool interiors_overlap(const Point2d (&a)[3], const Point2d (&b)[3], double tol) {
  const auto separated = [tol](const Point2d(&p)[3], const Point2d(&q)[3]) {
    for (int e = 0; e < 3; ++e) {
      const Point2d& s = p[e];
      const Point2d& t = p[(e + 1) % 3];
      // Outward normal of a counter-clockwise edge: (dy, -dx).
      const double nx = t.y - s.y, ny = s.x - t.x;
      const double len = std::hypot(nx, ny);
      if (!(len > 0)) continue;
      double qmin = INFINITY;
      for (const Point2d& v : q) qmin = std::min(qmin, (nx * (v.x - s.x) + ny * (v.y - s.y)) / len);
      if (qmin >= -tol) return true;  // all of q on or outside this edge of p
    }
    return false;
  };
  return !separated(a, b) && !separated(b, a);
}

// Calls visit(cell id) for each cell of `grid` that the box [a, b] overlaps (clamped to the grid; none for a box
// wholly outside it or not finite) until one returns true; returns whether one did.
template <class Grid, class Visit>
bool for_each_cell(const Grid& grid, const Vec3& a, const Vec3& b, Visit visit) {
  const double la[3] = {a.x - grid.lower.x, a.y - grid.lower.y, a.z - grid.lower.z};
  const double lb[3] = {b.x - grid.lower.x, b.y - grid.lower.y, b.z - grid.lower.z};
  size_t c0[3], c1[3];
  for (int k = 0; k < 3; ++k) {
    const double extent = static_cast<double>(grid.n[k]) * grid.cell;
    // Also false for NaN: a sample at a non-finite position is near nothing.
    if (!(lb[k] >= 0 && la[k] < extent)) return false;
    c0[k] = std::min(grid.n[k] - 1, static_cast<size_t>(std::max(0.0, la[k] / grid.cell)));
    c1[k] = std::min(grid.n[k] - 1, static_cast<size_t>(std::min(extent, lb[k]) / grid.cell));
  }
  for (size_t z = c0[2]; z <= c1[2]; ++z)
    for (size_t y = c0[1]; y <= c1[1]; ++y)
      for (size_t x = c0[0]; x <= c1[0]; ++x)
        if (visit((z * grid.n[1] + y) * grid.n[0] + x)) return true;
  return false;
}

// For each vertex, the lowest-numbered vertex at the same position: the mesh's connectivity when it splits its
// vertices along UV seams or hard edges. "The same" is to 1e-9 of the mesh's size (the positions rounded to that
// grid): a pole made of sin(π) ≠ 0 is one point, and nothing a texel apart is merged.
std::vector<uint32_t> canonical_vertices(const scene::Mesh& mesh) {
  Vec3 lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
  for (const Vec3& p : mesh.positions) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  const double cell = 1e-9 * length(hi - lo);
  // A mesh of one point, or beyond double range: exact positions.
  const bool grid = cell > 0 && std::isfinite(cell);
  std::vector<std::array<double, 3>> key(mesh.positions.size());
  for (size_t v = 0; v < key.size(); ++v) {
    const Vec3& p = mesh.positions[v];
    key[v] = grid ? std::array<double, 3>{std::round((p.x - lo.x) / cell), std::round((p.y - lo.y) / cell),
                                          std::round((p.z - lo.z) / cell)}
                  : std::array<double, 3>{p.x, p.y, p.z};
  }
  std::vector<uint32_t> order(mesh.positions.size());
  for (uint32_t v = 0; v < order.size(); ++v) order[v] = v;
  const auto less = [&](uint32_t a, uint32_t b) { return key[a] < key[b]; };
  std::stable_sort(order.begin(), order.end(), less);
  std::vector<uint32_t> canonical(order.size());
  for (size_t i = 0; i < order.size(); ++i)
    canonical[order[i]] = i > 0 && !less(order[i - 1], order[i]) ? canonical[order[i - 1]] : order[i];
  return canonical;
}

// Whether every edge (by position) of the triangles with three distinct positions is used once in each direction:
// a closed surface, consistently oriented. A zero-area triangle with three distinct positions fails it (it has no
// side to be outside of).
bool closed_and_oriented(const scene::Mesh& mesh, const std::vector<uint32_t>& canonical) {
  std::unordered_map<uint64_t, uint32_t> directed;
  const auto key = [](uint32_t a, uint32_t b) { return (uint64_t{a} << 32) | b; };
  const size_t nt = mesh.indices.size() / 3;
  for (size_t t = 0; t < nt; ++t) {
    const uint32_t v[3] = {canonical[mesh.indices[3 * t]], canonical[mesh.indices[3 * t + 1]],
                           canonical[mesh.indices[3 * t + 2]]};
    if (v[0] == v[1] || v[1] == v[2] || v[2] == v[0]) continue;  // collapsed (a pole's fan): no edge, no area
    const Vec3& p0 = mesh.positions[v[0]];
    if (!(length(cross(mesh.positions[v[1]] - p0, mesh.positions[v[2]] - p0)) > 0)) return false;
    for (int e = 0; e < 3; ++e) ++directed[key(v[e], v[(e + 1) % 3])];
  }
  for (const auto& [k, n] : directed) {
    const auto reverse = directed.find(key(static_cast<uint32_t>(k & 0xffffffffu), static_cast<uint32_t>(k >> 32)));
    if (n != 1 || reverse == directed.end() || reverse->second != 1) return false;
  }
  return !directed.empty();
}

// The inverse of an affine transform (its 3×3 part invertible: scene_check refuses singular ones).
scene::Transform inverse(const scene::Transform& t) {
  const auto& m = t.m;
  const double det = scene::determinant(t);
  const double c[9] = {m[5] * m[10] - m[6] * m[9], m[2] * m[9] - m[1] * m[10], m[1] * m[6] - m[2] * m[5],
                       m[6] * m[8] - m[4] * m[10], m[0] * m[10] - m[2] * m[8], m[2] * m[4] - m[0] * m[6],
                       m[4] * m[9] - m[5] * m[8],  m[1] * m[8] - m[0] * m[9],  m[0] * m[5] - m[1] * m[4]};
  scene::Transform r;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) r.m[4 * i + j] = c[3 * i + j] / det;
    r.m[4 * i + 3] = -(r.m[4 * i] * m[3] + r.m[4 * i + 1] * m[7] + r.m[4 * i + 2] * m[11]);
  }
  return r;
}

// Per triangle, 1 where it meets another at a point (by position) with normals 90° or more apart; with
// `concave_only`, only where one has a corner in front of the other's plane (a valley, not a ridge). Such a crease
// puts a point on it, lifted off one triangle along its normal, behind the other: the probe would see that one's back.
std::vector<uint8_t> sharp_creases(const scene::Mesh& mesh, const std::vector<uint32_t>& canonical, bool concave_only) {
  const size_t nt = mesh.indices.size() / 3;
  const auto corner = [&](size_t t, int k) -> const Vec3& { return mesh.positions[mesh.indices[3 * t + k]]; };
  std::vector<Vec3> unit(nt);
  for (size_t t = 0; t < nt; ++t) unit[t] = normalize(cross(corner(t, 1) - corner(t, 0), corner(t, 2) - corner(t, 0)));
  // In front of the other's plane by more than 1e-9 of its edge: rounding is far below, a texel far above.
  const auto in_front = [&](size_t a, size_t b) {
    for (int k = 0; k < 3; ++k)
      if (dot(unit[a], corner(b, k) - corner(a, 0)) > 1e-9 * length(corner(a, 1) - corner(a, 0))) return true;
    return false;
  };
  std::vector<uint32_t> first(mesh.positions.size() + 1, 0);
  for (uint32_t i : mesh.indices) ++first[canonical[i] + 1];
  for (size_t v = 1; v < first.size(); ++v) first[v] += first[v - 1];
  std::vector<uint32_t> incident(mesh.indices.size()), fill(first.begin(), first.end() - 1);
  for (size_t k = 0; k < mesh.indices.size(); ++k) incident[fill[canonical[mesh.indices[k]]]++] = k / 3;
  std::vector<uint8_t> flagged(nt, 0);
  for (size_t v = 0; v + 1 < first.size(); ++v) {
    for (uint32_t i = first[v]; i < first[v + 1]; ++i) {
      for (uint32_t j = i + 1; j < first[v + 1]; ++j) {
        const size_t a = incident[i], b = incident[j];
        if (dot(unit[a], unit[b]) > 0) continue;
        if (!concave_only || in_front(a, b) || in_front(b, a)) flagged[a] = flagged[b] = 1;
      }
    }
  }
  return flagged;
}

// Whether p lies within `margin` of the box of the triangle (a, b, c).
bool near_triangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, double margin) {
  const auto within = [margin](double x, double u, double v, double w) {
    return x >= std::min({u, v, w}) - margin && x <= std::max({u, v, w}) + margin;
  };
  return within(p.x, a.x, b.x, c.x) && within(p.y, a.y, b.y, c.y) && within(p.z, a.z, b.z, c.z);
}

// Per triangle, 1 where one of its edges (by position) belongs to no other triangle: the border of an open mesh.
std::vector<uint8_t> border_triangles(const scene::Mesh& mesh, const std::vector<uint32_t>& canonical) {
  const size_t nt = mesh.indices.size() / 3;
  std::vector<std::pair<uint64_t, uint32_t>> edges;  // (edge by its two vertices, lower first; triangle)
  edges.reserve(3 * nt);
  for (size_t t = 0; t < nt; ++t) {
    for (int e = 0; e < 3; ++e) {
      const uint32_t a = canonical[mesh.indices[3 * t + e]], b = canonical[mesh.indices[3 * t + (e + 1) % 3]];
      edges.emplace_back((uint64_t{std::min(a, b)} << 32) | std::max(a, b), static_cast<uint32_t>(t));
    }
  }
  std::sort(edges.begin(), edges.end());
  std::vector<uint8_t> border(nt, 0);
  for (size_t i = 0; i < edges.size();) {
    size_t j = i + 1;
    while (j < edges.size() && edges[j].first == edges[i].first) ++j;
    if (j - i == 1) border[edges[i].second] = 1;
    i = j;
  }
  return border;
}

}  // namespace

// Closed, oriented, every triangle facing away from the centre c (its plane has c strictly behind it), and the solid
// angles the triangles subtend at c summing to 4π: then each direction from c meets the surface once, so the surface
// is a radial graph around c (no fold, no self-intersection, no second shell) and c is inside.
bool is_star_shaped_closed(const scene::Mesh& mesh) { return star_centre(mesh).has_value(); }

std::optional<Vec3> star_centre(const scene::Mesh& mesh) {
  const std::vector<uint32_t> canonical = canonical_vertices(mesh);
  if (!closed_and_oriented(mesh, canonical)) return std::nullopt;
  const size_t nt = mesh.indices.size() / 3;
  Vec3 c{};
  double area = 0;
  for (size_t t = 0; t < nt; ++t) {
    const Vec3 &a = mesh.positions[mesh.indices[3 * t]], &b = mesh.positions[mesh.indices[3 * t + 1]],
               &d = mesh.positions[mesh.indices[3 * t + 2]];
    const double w = length(cross(b - a, d - a));
    c = c + (a + b + d) * (w / 3);
    area += w;
  }
  if (!(area > 0) || !std::isfinite(area)) return std::nullopt;
  c = c * (1 / area);
  double solid_angle = 0;
  for (size_t t = 0; t < nt; ++t) {
    const Vec3 a = mesh.positions[mesh.indices[3 * t]] - c, b = mesh.positions[mesh.indices[3 * t + 1]] - c,
               d = mesh.positions[mesh.indices[3 * t + 2]] - c;
    const Vec3 n = cross(b - a, d - a);
    const double ln = length(n);
    if (!(ln > 0)) continue;  // collapsed: it subtends nothing
    // Facing away from c by more than rounding: 1e-9 of the distance, far above double rounding, far below a texel.
    if (!(dot(n, a) > 1e-9 * ln * length(a))) return std::nullopt;
    // Van Oosterom and Strackee's solid angle of the triangle (a, b, d) seen from the origin.
    const double la = length(a), lb = length(b), ld = length(d);
    solid_angle += 2 * std::atan2(dot(a, cross(b, d)), la * lb * ld + dot(a, b) * ld + dot(a, d) * lb + dot(b, d) * la);
  }
  // One shell covers the sphere of directions once (4π); two would cover it twice. 1e-6: rounding of the sum.
  if (!(std::abs(solid_angle - 4 * kPi) < 1e-6 * 4 * kPi)) return std::nullopt;
  return c;
}

bool inside_star_shaped(const scene::Mesh& mesh, const Vec3& centre, const Vec3& q) {
  const Vec3 d = q - centre;
  const size_t nt = mesh.indices.size() / 3;
  for (size_t t = 0; t < nt; ++t) {
    const Vec3 a = mesh.positions[mesh.indices[3 * t]] - centre, b = mesh.positions[mesh.indices[3 * t + 1]] - centre,
               e = mesh.positions[mesh.indices[3 * t + 2]] - centre;
    // The triangle whose cone from the centre holds d (each faces away from the centre: the three triple products
    // have the sign of its normal's dot with a, positive).
    if (dot(d, cross(a, b)) < 0 || dot(d, cross(b, e)) < 0 || dot(d, cross(e, a)) < 0) continue;
    const Vec3 n = cross(b - a, e - a);
    const double along = dot(n, d);
    if (!(along > 0)) continue;  // collapsed, or d along its edge
    // The surface crosses the ray centre + s·d at s = (n·a)/(n·d): q (s = 1) is inside when the crossing is beyond.
    return dot(n, a) >= along;
  }
  return true;  // no triangle's cone holds d (rounding at an edge shared by two): inside, so probed
}

std::vector<uint8_t> sharp_valley_triangles(const scene::Mesh& mesh) {
  return sharp_creases(mesh, canonical_vertices(mesh), true);
}

bool is_convex_mesh(const scene::Mesh& mesh) {
  const size_t nt = mesh.indices.size() / 3;
  if (nt == 0) return false;
  const std::vector<uint8_t> used = used_vertices(mesh);
  std::vector<Vec3> verts;
  for (size_t v = 0; v < used.size(); ++v)
    if (used[v]) verts.push_back(mesh.positions[v]);
  if (static_cast<double>(nt) * static_cast<double>(verts.size()) > kMaxConvexTests) return false;
  Vec3 lo = verts[0], hi = verts[0];
  for (const Vec3& v : verts) {
    lo = {std::min(lo.x, v.x), std::min(lo.y, v.y), std::min(lo.z, v.z)};
    hi = {std::max(hi.x, v.x), std::max(hi.y, v.y), std::max(hi.z, v.z)};
  }
  // "On the plane" within 1e-6 of the mesh's size: far below a texel, far above its float rounding.
  const double tol = 1e-6 * length(hi - lo);
  std::atomic<bool> convex{true};
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nt, 64), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t t = r.begin(); t < r.end() && convex.load(std::memory_order_relaxed); ++t) {
      const Vec3& p0 = mesh.positions[mesh.indices[3 * t]];
      const Vec3 c = cross(mesh.positions[mesh.indices[3 * t + 1]] - p0, mesh.positions[mesh.indices[3 * t + 2]] - p0);
      const double len = length(c);
      if (!(len > 0)) continue;  // no front to look out of
      const Vec3 n = c * (1.0 / len);
      for (const Vec3& v : verts) {
        if (dot(n, v - p0) > tol) {
          convex = false;
          break;
        }
      }
    }
  });
  return convex.load();
}

bool is_height_field(const scene::Mesh& mesh) { return height_field_direction(mesh).has_value(); }

std::optional<Vec3> height_field_direction(const scene::Mesh& mesh) {
  const size_t nt = mesh.indices.size() / 3;
  if (nt == 0) return std::nullopt;
  const auto tri_cross = [&](size_t t) {
    const Vec3& p0 = mesh.positions[mesh.indices[3 * t]];
    return cross(mesh.positions[mesh.indices[3 * t + 1]] - p0, mesh.positions[mesh.indices[3 * t + 2]] - p0);
  };
  Vec3 sum{};
  for (size_t t = 0; t < nt; ++t) sum = sum + tri_cross(t);
  const double sl = length(sum);
  if (!(sl > 0)) return std::nullopt;
  const Vec3 d = sum * (1.0 / sl);
  double area = 0;  // projected, doubled
  for (size_t t = 0; t < nt; ++t) {
    const Vec3 c = tri_cross(t);
    const double along = dot(c, d);
    // Strictly facing d (a vertical or overhanging triangle is not part of a height field along d).
    if (!(along > 1e-6 * length(c))) return std::nullopt;
    area += along;
  }
  // Triangles meeting at a point (by position: a mesh may split its vertices) must have normals less than 90° apart:
  // a point on their common edge or corner, lifted off the surface along one's normal, is then in front of the
  // other's plane too. A sharper valley puts it behind its neighbour (a crease of a coarse, steep terrain: the probe
  // sees the neighbour's back), which the argument above needs to exclude.
  {
    const std::vector<uint8_t> creases = sharp_creases(mesh, canonical_vertices(mesh), false);
    if (std::find(creases.begin(), creases.end(), 1) != creases.end()) return std::nullopt;
  }
  // Project along d onto a basis (e1, e2) with e1 × e2 = d: every triangle is counter-clockwise there.
  const Frame frame = Frame::from_normal(d);
  const Vec3 e1 = frame.from_local({1, 0, 0}), e2 = frame.from_local({0, 1, 0});
  const double orient = dot(cross(e1, e2), d) > 0 ? 1.0 : -1.0;
  std::vector<Point2d> q(mesh.positions.size());
  for (size_t v = 0; v < q.size(); ++v) q[v] = {dot(mesh.positions[v], e1), orient * dot(mesh.positions[v], e2)};
  Point2d lo{INFINITY, INFINITY}, hi{-INFINITY, -INFINITY};
  for (uint32_t i : mesh.indices) {
    lo = {std::min(lo.x, q[i].x), std::min(lo.y, q[i].y)};
    hi = {std::max(hi.x, q[i].x), std::max(hi.y, q[i].y)};
  }
  // A grid of cells about a triangle pair's size, at most 4 cells a triangle.
  double cell = std::sqrt(area / static_cast<double>(nt));
  const double wx = hi.x - lo.x, wy = hi.y - lo.y;
  cell = std::max({cell, std::sqrt(wx * wy / (4.0 * static_cast<double>(nt))), 1e-300});
  const size_t nx = static_cast<size_t>(wx / cell) + 1, ny = static_cast<size_t>(wy / cell) + 1;
  const double tol = 1e-7 * cell;
  const auto cell_of = [&](double x, double y) {
    const size_t ix = std::min(nx - 1, static_cast<size_t>(std::max(0.0, (x - lo.x) / cell)));
    const size_t iy = std::min(ny - 1, static_cast<size_t>(std::max(0.0, (y - lo.y) / cell)));
    return std::pair{ix, iy};
  };
  struct Box {
    Point2d lo, hi;
  };
  std::vector<Box> boxes(nt);
  std::vector<uint32_t> count(nx * ny + 1, 0);
  for (size_t t = 0; t < nt; ++t) {
    Box b{{INFINITY, INFINITY}, {-INFINITY, -INFINITY}};
    for (int j = 0; j < 3; ++j) {
      const Point2d& p = q[mesh.indices[3 * t + j]];
      b.lo = {std::min(b.lo.x, p.x), std::min(b.lo.y, p.y)};
      b.hi = {std::max(b.hi.x, p.x), std::max(b.hi.y, p.y)};
    }
    boxes[t] = b;
    const auto [x0, y0] = cell_of(b.lo.x, b.lo.y);
    const auto [x1, y1] = cell_of(b.hi.x, b.hi.y);
    for (size_t y = y0; y <= y1; ++y)
      for (size_t x = x0; x <= x1; ++x) ++count[y * nx + x + 1];
  }
  for (size_t c = 1; c < count.size(); ++c) count[c] += count[c - 1];
  std::vector<uint32_t> items(count.back());
  std::vector<uint32_t> fill(count.begin(), count.end() - 1);
  for (size_t t = 0; t < nt; ++t) {
    const auto [x0, y0] = cell_of(boxes[t].lo.x, boxes[t].lo.y);
    const auto [x1, y1] = cell_of(boxes[t].hi.x, boxes[t].hi.y);
    for (size_t y = y0; y <= y1; ++y)
      for (size_t x = x0; x <= x1; ++x) items[fill[y * nx + x]++] = static_cast<uint32_t>(t);
  }
  std::atomic<bool> overlap{false};
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nx * ny, 256), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t c = r.begin(); c < r.end() && !overlap.load(std::memory_order_relaxed); ++c) {
      for (uint32_t i = count[c]; i < count[c + 1]; ++i) {
        for (uint32_t j = i + 1; j < count[c + 1]; ++j) {
          const Box &a = boxes[items[i]], &b = boxes[items[j]];
          const Point2d corner{std::max(a.lo.x, b.lo.x), std::max(a.lo.y, b.lo.y)};
          if (corner.x > std::min(a.hi.x, b.hi.x) || corner.y > std::min(a.hi.y, b.hi.y)) continue;
          // Each pair once: in the cell holding the lower corner of the boxes' overlap.
          const auto [cx, cy] = cell_of(corner.x, corner.y);
          if (cy * nx + cx != c) continue;
          Point2d ta[3], tb[3];
          for (int k = 0; k < 3; ++k) {
            ta[k] = q[mesh.indices[3 * size_t{items[i]} + k]];
            tb[k] = q[mesh.indices[3 * size_t{items[j]} + k]];
          }
          if (interiors_overlap(ta, tb, tol)) {
            overlap = true;
            return;
          }
        }
      }
    }
  });
  if (overlap.load()) return std::nullopt;
  return d;
}

LeakScope::LeakScope(const scene::Scene& scene, const LeakScopeOptions& options, const bake::StopCheck& stop)
    : scene_(scene), options_(options) {
  if (!(options.margin_texels > 0) || !std::isfinite(options.margin_texels))
    throw std::invalid_argument("leak scope: margin_texels must be finite and > 0");
  if (options.chunk_triangles < 1) throw std::invalid_argument("leak scope: chunk_triangles must be >= 1");
  if (!(options.height_field_clearance_texels >= 0) || !std::isfinite(options.height_field_clearance_texels))
    throw std::invalid_argument("leak scope: height_field_clearance_texels must be finite and >= 0");
  const size_t nm = scene.meshes.size();
  std::vector<uint8_t> baked(nm, 0);
  for (const scene::Instance& inst : scene.instances)
    if (inst.bake) baked[static_cast<size_t>(inst.mesh)] = 1;
  self_hiding_.assign(nm, 1);
  convex_.assign(nm, 0);
  star_centre_.assign(nm, std::nullopt);
  height_up_.assign(nm, std::nullopt);
  border_triangles_.assign(nm, {});
  valley_triangles_.assign(nm, {});
  for (size_t m = 0; m < nm; ++m) {
    if (scene.meshes[m].indices.empty()) continue;
    stop.check();
    // Every mesh's convexity: a convex mesh may hide another instance's points only from inside it. A closed one
    // (a crate, a pillar) is star-shaped about its centroid, and tested exactly as such, without the margin that
    // an open one (a lone wall) needs for the points straddling it.
    convex_[m] = is_convex_mesh(scene.meshes[m]);
    if (convex_[m]) {
      star_centre_[m] = star_centre(scene.meshes[m]);
    } else if ((height_up_[m] = height_field_direction(scene.meshes[m]))) {
      border_triangles_[m] = border_triangles(scene.meshes[m], canonical_vertices(scene.meshes[m]));
    }
    if (!baked[m]) continue;
    if (convex_[m]) {
      self_hiding_[m] = 0;
      ++summary_.convex_meshes;
    } else if (height_up_[m]) {
      self_hiding_[m] = 0;
      ++summary_.height_field_meshes;
    } else if (const std::optional<Vec3> centre = star_centre(scene.meshes[m])) {
      self_hiding_[m] = 0;
      star_centre_[m] = *centre;
      ++summary_.star_shaped_meshes;
      valley_triangles_[m] = sharp_valley_triangles(scene.meshes[m]);
      for (uint8_t v : valley_triangles_[m]) summary_.valley_triangles += v;
    } else {
      ++summary_.probed_meshes;
    }
  }
  const size_t per_chunk = static_cast<size_t>(options.chunk_triangles);
  winding_.reserve(scene.instances.size());
  for (size_t k = 0; k < scene.instances.size(); ++k) {
    stop.check();
    const scene::Instance& inst = scene.instances[k];
    winding_.push_back(scene::determinant(inst.to_world) < 0 ? -1 : 1);
    to_object_.push_back(star_centre_[static_cast<size_t>(inst.mesh)] ? inverse(inst.to_world) : scene::Transform{});
    const scene::Mesh& mesh = scene.meshes[static_cast<size_t>(inst.mesh)];
    const size_t nt = mesh.indices.size() / 3;
    for (size_t t0 = 0; t0 < nt; t0 += per_chunk) {
      const size_t t1 = std::min(nt, t0 + per_chunk);
      Chunk c{{INFINITY, INFINITY, INFINITY},
              {-INFINITY, -INFINITY, -INFINITY},
              static_cast<uint32_t>(k),
              static_cast<uint32_t>(t0),
              static_cast<uint32_t>(t1 - t0)};
      for (size_t i = 3 * t0; i < 3 * t1; ++i) {
        const Vec3 w = inst.to_world.point(mesh.positions[mesh.indices[i]]);
        c.lower = {std::min(c.lower.x, w.x), std::min(c.lower.y, w.y), std::min(c.lower.z, w.z)};
        c.upper = {std::max(c.upper.x, w.x), std::max(c.upper.y, w.y), std::max(c.upper.z, w.z)};
      }
      chunks_.push_back(c);
    }
  }
  summary_.chunks = chunks_.size();
  build_grid();
}

// The grid's cell is the chunks' median extent (most chunks span one or two cells a side) or, for a few large
// chunks, what gives about eight cells a chunk; a chunk is listed in every cell its box overlaps.
void LeakScope::build_grid() {
  if (chunks_.empty()) return;
  Vec3 lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
  std::vector<double> extents;
  extents.reserve(chunks_.size());
  for (const Chunk& c : chunks_) {
    lo = {std::min(lo.x, c.lower.x), std::min(lo.y, c.lower.y), std::min(lo.z, c.lower.z)};
    hi = {std::max(hi.x, c.upper.x), std::max(hi.y, c.upper.y), std::max(hi.z, c.upper.z)};
    const Vec3 e = c.upper - c.lower;
    extents.push_back(std::max({e.x, e.y, e.z}));
  }
  const Vec3 w = hi - lo;
  const double widest = std::max({w.x, w.y, w.z});
  // A scene beyond double range has no usable grid: every sample then tests every chunk's box (exact, slower).
  if (!std::isfinite(widest)) return;
  std::nth_element(extents.begin(), extents.begin() + extents.size() / 2, extents.end());
  // Guard: a scene of one flat point (all extents 0) still needs a cell > 0.
  grid_.cell = std::max({extents[extents.size() / 2], std::cbrt(w.x * w.y * w.z / (8.0 * chunks_.size())),
                         1e-9 * widest, std::numeric_limits<double>::min()});
  grid_.lower = lo;
  const double dims[3] = {w.x, w.y, w.z};
  for (int a = 0; a < 3; ++a) grid_.n[a] = static_cast<size_t>(dims[a] / grid_.cell) + 1;
  grid_.first.assign(grid_.n[0] * grid_.n[1] * grid_.n[2] + 1, 0);
  for (int pass = 0; pass < 2; ++pass) {
    std::vector<uint32_t> fill;
    if (pass == 1) {
      for (size_t c = 1; c < grid_.first.size(); ++c) grid_.first[c] += grid_.first[c - 1];
      grid_.items.resize(grid_.first.back());
      fill.assign(grid_.first.begin(), grid_.first.end() - 1);
    }
    for (size_t i = 0; i < chunks_.size(); ++i) {
      for_each_cell(grid_, chunks_[i].lower, chunks_[i].upper, [&](size_t id) {
        if (pass == 0)
          ++grid_.first[id + 1];
        else
          grid_.items[fill[id]++] = static_cast<uint32_t>(i);
        return false;
      });
    }
  }
}

// Whether the chunk's triangles may show p a back face: p behind, or within `margin` in front of, the plane of one of
// them (in world space, front as the tracer's: the winding's normal, turned by a mirroring transform). Of a convex
// mesh, only when p is behind or within the margin of every one: a single plane with p farther in front puts p
// outside the whole mesh by more than the margin, where no part of it can hide p.
bool LeakScope::may_hide(const Chunk& chunk, const TexelSample& s, double margin) const {
  const Vec3& p = s.position;
  const scene::Instance& inst = scene_.instances[chunk.instance];
  const scene::Mesh& mesh = scene_.meshes[static_cast<size_t>(inst.mesh)];
  const double winding = winding_[chunk.instance];
  // A closed star-shaped mesh shows a point outside it only front faces (a ray from outside a closed surface meets a
  // front face first): it may hide only the points inside it. The test is exact in its object space.
  if (const std::optional<Vec3>& centre = star_centre_[static_cast<size_t>(inst.mesh)]) {
    return inside_star_shaped(mesh, *centre, to_object_[chunk.instance].point(p));
  }
  if (const std::optional<Vec3>& up = height_up_[static_cast<size_t>(inst.mesh)]) {
    const double clearance = options_.height_field_clearance_texels * s.texel_world_size + s.ray_offset;
    return height_field_may_hide(chunk, p, margin, clearance, inst.to_world.vector(*up));
  }
  const bool convex = convex_[static_cast<size_t>(inst.mesh)] != 0;
  for (size_t t = chunk.first_triangle; t < size_t{chunk.first_triangle} + chunk.triangles; ++t) {
    const Vec3 a = inst.to_world.point(mesh.positions[mesh.indices[3 * t]]);
    const Vec3 b = inst.to_world.point(mesh.positions[mesh.indices[3 * t + 1]]);
    const Vec3 c = inst.to_world.point(mesh.positions[mesh.indices[3 * t + 2]]);
    const Vec3 n = cross(b - a, c - a) * winding;
    const double ln = length(n);
    // A zero or non-finite normal (a degenerate triangle) has no plane: it keeps the chunk's probe, and is no
    // witness that p is outside a convex mesh.
    if (!(ln > 0) || !std::isfinite(ln)) {
      if (!convex) return true;
      continue;
    }
    const bool far_in_front = dot(n, p - a) > margin * ln;
    if (convex && far_in_front) return false;
    if (!convex && !far_in_front) return true;
  }
  return convex;
}

// A height field's surface splits space into above and below (along `up`, its direction in world space, the side its
// front faces look to): from above it, a ray meets its front faces only. So the chunk's triangle straight under or
// over p decides: p more than `clearance` above it (the probe's lift, leaks.h, stays above the ground) cannot be shown
// a back face of the whole mesh; p below it or closer may. A chunk with no triangle in p's column says nothing of p, unless p is within the margin of one of
// its triangles on the mesh's border: beside the border p may see its underside, and the plane of that triangle
// judges as for any open mesh.
bool LeakScope::height_field_may_hide(const Chunk& chunk, const Vec3& p, double margin, double clearance,
                                      const Vec3& up) const {
  const scene::Instance& inst = scene_.instances[chunk.instance];
  const scene::Mesh& mesh = scene_.meshes[static_cast<size_t>(inst.mesh)];
  const std::vector<uint8_t>& border = border_triangles_[static_cast<size_t>(inst.mesh)];
  const double winding = winding_[chunk.instance];
  bool beside_border = false;
  for (size_t t = chunk.first_triangle; t < size_t{chunk.first_triangle} + chunk.triangles; ++t) {
    const Vec3 a = inst.to_world.point(mesh.positions[mesh.indices[3 * t]]);
    const Vec3 e1 = inst.to_world.point(mesh.positions[mesh.indices[3 * t + 1]]) - a;
    const Vec3 e2 = inst.to_world.point(mesh.positions[mesh.indices[3 * t + 2]]) - a;
    const Vec3 n = cross(e1, e2) * winding;
    const double ln = length(n);
    const bool far_in_front = dot(n, p - a) > margin * ln;
    if (border[t] && !far_in_front && near_triangle(p, a, a + e1, a + e2, margin)) beside_border = true;
    // p = a + u·e1 + v·e2 + s·up, by Cramer's rule. The determinant is up·(e1 × e2), which is not 0: every triangle
    // of a height field faces along its direction (height_field_direction), and the instance's transform is
    // invertible (scene_check).
    const double det = dot(up, cross(e1, e2));
    const Vec3 q = p - a;
    const double u = dot(q, cross(e2, up)) / det, v = dot(e1, cross(q, up)) / det;
    // In the column within 1e-9 of the triangle's barycentric extent: a column through a shared edge, rounded,
    // falls in both its triangles rather than in neither.
    constexpr double kTol = 1e-9;
    if (u >= -kTol && v >= -kTol && u + v <= 1 + kTol) return !(dot(n, p - a) > clearance * ln);
  }
  return beside_border;
}

// Whether the sample lies within its margin of a chunk of another instance that may hide it (may_hide).
bool LeakScope::near_other_instance(const TexelSample& s) const {
  const Vec3& p = s.position;
  const double m = options_.margin_texels * static_cast<double>(s.texel_world_size);
  // A closed star-shaped instance answers for its whole mesh, not the chunk: tested once per sample, however many of
  // its chunks are near.
  uint32_t star_tested = UINT32_MAX;
  bool star_hides = false;
  const auto near = [&](const Chunk& ch) {
    if (ch.instance == s.triangle.instance ||
        !(p.x >= ch.lower.x - m && p.x <= ch.upper.x + m && p.y >= ch.lower.y - m && p.y <= ch.upper.y + m &&
          p.z >= ch.lower.z - m && p.z <= ch.upper.z + m)) {
      return false;
    }
    if (!star_centre_[static_cast<size_t>(scene_.instances[ch.instance].mesh)]) return may_hide(ch, s, m);
    if (ch.instance != star_tested) {
      star_tested = ch.instance;
      star_hides = may_hide(ch, s, m);
    }
    return star_hides;
  };
  if (grid_.n[0] == 0) return std::any_of(chunks_.begin(), chunks_.end(), near);
  const Vec3 reach{m, m, m};
  return for_each_cell(grid_, p - reach, p + reach, [&](size_t id) {
    for (uint32_t i = grid_.first[id]; i < grid_.first[id + 1]; ++i)
      if (near(chunks_[grid_.items[i]])) return true;
    return false;
  });
}

std::vector<uint8_t> LeakScope::probe_mask(std::span<const TexelSample> samples, const bake::StopCheck& stop) const {
  std::vector<uint8_t> mask(samples.size(), 0);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, samples.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
    stop.check();
    for (size_t j = r.begin(); j < r.end(); ++j) {
      const TexelSample& s = samples[j];
      const std::vector<uint8_t>& valleys = valley_triangles_[s.triangle.mesh];
      mask[j] = self_hiding_[s.triangle.mesh] ||
                (s.triangle.triangle < valleys.size() && valleys[s.triangle.triangle]) || near_other_instance(s);
    }
  });
  return mask;
}

}  // namespace kiln::lightmap
