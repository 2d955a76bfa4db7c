#include "bakers/lightmap/leak_scope.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

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
  const auto separated = [tol](const Point2d (&p)[3], const Point2d (&q)[3]) {
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

}  // namespace

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

bool is_height_field(const scene::Mesh& mesh) {
  const size_t nt = mesh.indices.size() / 3;
  if (nt == 0) return false;
  const auto tri_cross = [&](size_t t) {
    const Vec3& p0 = mesh.positions[mesh.indices[3 * t]];
    return cross(mesh.positions[mesh.indices[3 * t + 1]] - p0, mesh.positions[mesh.indices[3 * t + 2]] - p0);
  };
  Vec3 sum{};
  for (size_t t = 0; t < nt; ++t) sum = sum + tri_cross(t);
  const double sl = length(sum);
  if (!(sl > 0)) return false;
  const Vec3 d = sum * (1.0 / sl);
  double area = 0;  // projected, doubled
  for (size_t t = 0; t < nt; ++t) {
    const Vec3 c = tri_cross(t);
    const double along = dot(c, d);
    // Strictly facing d (a vertical or overhanging triangle is not part of a height field along d).
    if (!(along > 1e-6 * length(c))) return false;
    area += along;
  }
  // Triangles meeting at a point (by position: a mesh may split its vertices) must have normals less than 90° apart:
  // a point on their common edge or corner, lifted off the surface along one's normal, is then in front of the
  // other's plane too. A sharper valley puts it behind its neighbour (a crease of a coarse, steep terrain: the probe
  // sees the neighbour's back), which the argument above needs to exclude.
  {
    std::vector<uint32_t> order(mesh.positions.size());
    for (uint32_t v = 0; v < order.size(); ++v) order[v] = v;
    const auto less = [&](uint32_t a, uint32_t b) {
      const Vec3 &p = mesh.positions[a], &q = mesh.positions[b];
      return p.x != q.x ? p.x < q.x : p.y != q.y ? p.y < q.y : p.z < q.z;
    };
    std::sort(order.begin(), order.end(), less);
    std::vector<uint32_t> canonical(order.size());
    for (size_t i = 0; i < order.size(); ++i)
      canonical[order[i]] = i > 0 && !less(order[i - 1], order[i]) ? canonical[order[i - 1]] : order[i];
    std::vector<uint32_t> first(mesh.positions.size() + 1, 0);
    for (uint32_t i : mesh.indices) ++first[canonical[i] + 1];
    for (size_t v = 1; v < first.size(); ++v) first[v] += first[v - 1];
    std::vector<uint32_t> incident(mesh.indices.size()), fill(first.begin(), first.end() - 1);
    for (size_t k = 0; k < mesh.indices.size(); ++k) incident[fill[canonical[mesh.indices[k]]]++] = k / 3;
    std::vector<Vec3> unit(nt);
    for (size_t t = 0; t < nt; ++t) unit[t] = normalize(tri_cross(t));
    for (size_t v = 0; v + 1 < first.size(); ++v)
      for (uint32_t i = first[v]; i < first[v + 1]; ++i)
        for (uint32_t j = i + 1; j < first[v + 1]; ++j)
          if (!(dot(unit[incident[i]], unit[incident[j]]) > 0)) return false;
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
  return !overlap.load();
}

LeakScope::LeakScope(const scene::Scene& scene, const LeakScopeOptions& options, const bake::StopCheck& stop)
    : options_(options) {
  if (!(options.margin_texels > 0) || !std::isfinite(options.margin_texels))
    throw std::invalid_argument("leak scope: margin_texels must be finite and > 0");
  if (options.chunk_triangles < 1) throw std::invalid_argument("leak scope: chunk_triangles must be >= 1");
  const size_t nm = scene.meshes.size();
  std::vector<uint8_t> baked(nm, 0);
  for (const scene::Instance& inst : scene.instances)
    if (inst.bake) baked[static_cast<size_t>(inst.mesh)] = 1;
  self_hiding_.assign(nm, 1);
  for (size_t m = 0; m < nm; ++m) {
    if (!baked[m] || scene.meshes[m].indices.empty()) continue;
    stop.check();
    if (is_convex_mesh(scene.meshes[m])) {
      self_hiding_[m] = 0;
      ++summary_.convex_meshes;
    } else if (is_height_field(scene.meshes[m])) {
      self_hiding_[m] = 0;
      ++summary_.height_field_meshes;
    } else {
      ++summary_.probed_meshes;
    }
  }
  const size_t per_chunk = static_cast<size_t>(options.chunk_triangles);
  for (size_t k = 0; k < scene.instances.size(); ++k) {
    stop.check();
    const scene::Instance& inst = scene.instances[k];
    const scene::Mesh& mesh = scene.meshes[static_cast<size_t>(inst.mesh)];
    const size_t nt = mesh.indices.size() / 3;
    for (size_t t0 = 0; t0 < nt; t0 += per_chunk) {
      Chunk c{{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}, static_cast<uint32_t>(k)};
      for (size_t i = 3 * t0; i < 3 * std::min(nt, t0 + per_chunk); ++i) {
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

// Whether the sample lies within its margin of a chunk of another instance.
bool LeakScope::near_other_instance(const TexelSample& s) const {
  const Vec3& p = s.position;
  const double m = options_.margin_texels * static_cast<double>(s.texel_world_size);
  const auto near = [&](const Chunk& ch) {
    return ch.instance != s.triangle.instance && p.x >= ch.lower.x - m && p.x <= ch.upper.x + m &&
           p.y >= ch.lower.y - m && p.y <= ch.upper.y + m && p.z >= ch.lower.z - m && p.z <= ch.upper.z + m;
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
      mask[j] = self_hiding_[s.triangle.mesh] || near_other_instance(s);
    }
  });
  return mask;
}

}  // namespace kiln::lightmap
