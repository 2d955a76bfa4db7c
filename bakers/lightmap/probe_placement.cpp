#include "bakers/lightmap/probe_placement.h"

#include <algorithm>
#include <cmath>
#include <unordered_set>

#include "bakers/bake/number_format.h"

namespace kiln::lightmap {
namespace {

using bake::format_number;

constexpr int64_t kMaxAxisPoints = int64_t{1} << 20;  // lattice indices pack into 21 bits each

struct Triangle {
  Vec3 a, b, c;
};

std::vector<Triangle> world_triangles(const scene::Scene& s) {
  std::vector<Triangle> out;
  for (const scene::Instance& inst : s.instances) {
    if (inst.mesh < 0 || static_cast<size_t>(inst.mesh) >= s.meshes.size()) continue;
    const scene::Mesh& m = s.meshes[inst.mesh];
    for (size_t t = 0; t + 2 < m.indices.size(); t += 3) {
      if (m.indices[t] >= m.positions.size() || m.indices[t + 1] >= m.positions.size() ||
          m.indices[t + 2] >= m.positions.size())
        continue;  // an index out of range: the scene check drops such a triangle too
      const Triangle w{inst.to_world.point(m.positions[m.indices[t]]),
                       inst.to_world.point(m.positions[m.indices[t + 1]]),
                       inst.to_world.point(m.positions[m.indices[t + 2]])};
      if (is_finite(w.a) && is_finite(w.b) && is_finite(w.c)) out.push_back(w);
    }
  }
  return out;
}

Vec3 min3(const Vec3& a, const Vec3& b) { return {std::min(a.x, b.x), std::min(a.y, b.y), std::min(a.z, b.z)}; }
Vec3 max3(const Vec3& a, const Vec3& b) { return {std::max(a.x, b.x), std::max(a.y, b.y), std::max(a.z, b.z)}; }
double axis(const Vec3& v, int a) { return a == 0 ? v.x : (a == 1 ? v.y : v.z); }

ProbeBox union_box(const std::vector<ProbeBox>& boxes) {
  ProbeBox u = boxes.front();
  for (const ProbeBox& b : boxes) u = {min3(u.lo, b.lo), max3(u.hi, b.hi)};
  return u;
}

// The lattice indices along one axis whose centres lie in [a, b].
struct IndexRange {
  int64_t lo = 0, hi = -1;
  bool empty() const { return hi < lo; }
};
IndexRange index_range(double a, double b, double origin, double s) {
  return {static_cast<int64_t>(std::ceil((a - origin) / s)), static_cast<int64_t>(std::floor((b - origin) / s))};
}

bool inside_any(const std::vector<ProbeBox>& regions, const Vec3& p) {
  for (const ProbeBox& r : regions) {
    if (p.x >= r.lo.x && p.x <= r.hi.x && p.y >= r.lo.y && p.y <= r.hi.y && p.z >= r.lo.z && p.z <= r.hi.z) return true;
  }
  return false;
}

// Lattice points in the union of the regions, counted over the cells between their index ranges' ends (at most
// (2·regions)³ cells), so overlaps count once.
uint64_t union_points(const std::vector<ProbeBox>& regions, const Vec3& origin, double s) {
  std::vector<std::array<IndexRange, 3>> boxes;
  std::array<std::vector<int64_t>, 3> cuts;
  for (const ProbeBox& r : regions) {
    std::array<IndexRange, 3> b;
    for (int a = 0; a < 3; ++a) b[a] = index_range(axis(r.lo, a), axis(r.hi, a), axis(origin, a), s);
    if (b[0].empty() || b[1].empty() || b[2].empty()) continue;
    boxes.push_back(b);
    for (int a = 0; a < 3; ++a) cuts[a].insert(cuts[a].end(), {b[a].lo, b[a].hi + 1});
  }
  for (auto& c : cuts) {
    std::sort(c.begin(), c.end());
    c.erase(std::unique(c.begin(), c.end()), c.end());
  }
  uint64_t n = 0;
  for (size_t x = 0; x + 1 < cuts[0].size(); ++x)
    for (size_t y = 0; y + 1 < cuts[1].size(); ++y)
      for (size_t z = 0; z + 1 < cuts[2].size(); ++z) {
        const std::array<int64_t, 3> q{cuts[0][x], cuts[1][y], cuts[2][z]};
        const bool covered = std::any_of(boxes.begin(), boxes.end(), [&](const auto& b) {
          return q[0] >= b[0].lo && q[0] <= b[0].hi && q[1] >= b[1].lo && q[1] <= b[1].hi && q[2] >= b[2].lo &&
                 q[2] <= b[2].hi;
        });
        if (covered) {
          n += static_cast<uint64_t>(cuts[0][x + 1] - q[0]) * static_cast<uint64_t>(cuts[1][y + 1] - q[1]) *
               static_cast<uint64_t>(cuts[2][z + 1] - q[2]);
        }
      }
  return n;
}

uint64_t key(int64_t i, int64_t j, int64_t k) {
  return static_cast<uint64_t>(i) | static_cast<uint64_t>(j) << 21 | static_cast<uint64_t>(k) << 42;
}

// One placement at spacing s; false with `why` when it does not fit (too many probes, or too fine a lattice).
bool try_place(const std::vector<Triangle>& tris, const ProbePlacementOptions& o, double s, const bake::StopCheck& stop,
               ProbePlacement& out, std::string& why) {
  const ProbeBox u = union_box(out.regions);
  out.origin = u.lo + Vec3{s, s, s} * 0.5;
  out.spacing = s;
  for (int a = 0; a < 3; ++a) {
    if ((axis(u.hi, a) - axis(out.origin, a)) / s >= static_cast<double>(kMaxAxisPoints)) {
      why = "spacing " + format_number(s) + " makes more than 2^20 lattice points along an axis of the regions";
      return false;
    }
  }
  const double d = o.max_distance;
  std::unordered_set<uint64_t> near;
  for (size_t t = 0; t < tris.size(); ++t) {
    const Triangle& tri = tris[t];
    const Vec3 lo = max3(min3(min3(tri.a, tri.b), tri.c) - Vec3{d, d, d}, u.lo);
    const Vec3 hi = min3(max3(max3(tri.a, tri.b), tri.c) + Vec3{d, d, d}, u.hi);
    const IndexRange ri = index_range(lo.x, hi.x, out.origin.x, s), rj = index_range(lo.y, hi.y, out.origin.y, s),
                     rk = index_range(lo.z, hi.z, out.origin.z, s);
    for (int64_t k = rk.lo; k <= rk.hi; ++k)
      for (int64_t j = rj.lo; j <= rj.hi; ++j) {
        stop.check();  // a long thin triangle across a large region visits many points it is far from
        for (int64_t i = ri.lo; i <= ri.hi; ++i) {
          const Vec3 p = out.origin + Vec3{double(i), double(j), double(k)} * s;
          if (near.count(key(i, j, k)) || !inside_any(out.regions, p)) continue;
          if (point_triangle_distance(p, tri.a, tri.b, tri.c) > d) continue;
          near.insert(key(i, j, k));
          if (near.size() > o.max_probes) {
            why = "spacing " + format_number(s) + " places more than max_probes (" + std::to_string(o.max_probes) +
                  ") probes within " + format_number(d) + " of the geometry";
            return false;
          }
        }
      }
  }
  for (uint64_t q : near) {
    const int i = static_cast<int>(q & 0x1fffff), j = static_cast<int>(q >> 21 & 0x1fffff),
              k = static_cast<int>(q >> 42);
    out.voxels.push_back({i, j, k});
  }
  std::sort(out.voxels.begin(), out.voxels.end(),
            [](const auto& a, const auto& b) { return std::tie(a[2], a[1], a[0]) < std::tie(b[2], b[1], b[0]); });
  for (const auto& v : out.voxels)
    out.positions.push_back(out.origin + Vec3{double(v[0]), double(v[1]), double(v[2])} * s);
  return true;
}

}  // namespace

double point_triangle_distance(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return length(ap);  // vertex region a
  const Vec3 bp = p - b;
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return length(bp);  // vertex region b
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return length(p - (a + ab * (d1 / (d1 - d3))));  // edge ab
  const Vec3 cp = p - c;
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return length(cp);  // vertex region c
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return length(p - (a + ac * (d2 / (d2 - d6))));  // edge ac
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
    return length(p - (b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)))));  // edge bc
  }
  const double denom = va + vb + vc;
  // A degenerate (zero-area) triangle that reached the face case: its nearest point lies on one of its edges.
  if (!(std::abs(denom) > 0)) return std::min({length(ap), length(bp), length(cp)});
  return length(p - (a + ab * (vb / denom) + ac * (vc / denom)));
}

ProbePlacement place_probes(const scene::Scene& scene, const ProbePlacementOptions& o, const bake::StopCheck& stop) {
  ProbePlacement out;
  out.spacing = o.spacing;
  const std::vector<Triangle> tris = world_triangles(scene);
  if (tris.empty()) {
    out.reasons.push_back("the scene has no triangle: no probe is near geometry, none placed");
    return out;
  }
  out.regions = o.regions;
  if (out.regions.empty()) {
    ProbeBox box{tris[0].a, tris[0].a};
    for (const Triangle& t : tris)
      box = {min3(min3(min3(box.lo, t.a), t.b), t.c), max3(max3(max3(box.hi, t.a), t.b), t.c)};
    const Vec3 grow{o.max_distance, o.max_distance, o.max_distance};
    out.regions.push_back({box.lo - grow, box.hi + grow});
    out.reasons.push_back("region: the scene's triangles' bounding box grown by max_distance " +
                          format_number(o.max_distance));
  }
  double s = o.spacing;
  std::string why;
  for (;;) {
    ProbePlacement attempt = out;
    if (try_place(tris, o, s, stop, attempt, why)) {
      out = std::move(attempt);
      break;
    }
    out.reasons.push_back(why + ": spacing doubled to " + format_number(2 * s));
    s *= 2;
    ++out.doublings;
  }
  out.lattice_points = union_points(out.regions, out.origin, out.spacing);
  out.skipped_far = out.lattice_points - std::min<uint64_t>(out.lattice_points, out.voxels.size());
  out.reasons.push_back(std::to_string(out.voxels.size()) + " of " + std::to_string(out.lattice_points) +
                        " lattice points at spacing " + format_number(out.spacing) + " lie within max_distance " +
                        format_number(o.max_distance) + " of a triangle; the other " + std::to_string(out.skipped_far) +
                        " are skipped");
  return out;
}

}  // namespace kiln::lightmap
