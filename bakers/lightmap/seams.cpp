#include "bakers/lightmap/seams.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <numeric>
#include <stdexcept>
#include <tuple>
#include <unordered_map>
#include <utility>

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "bakers/math/rgb.h"
#include "bakers/scene/scene_check.h"

namespace kiln::lightmap {
namespace {

bool finite(const Vec3& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }
bool finite(const Point2& p) { return std::isfinite(p.x) && std::isfinite(p.y); }
double distance(const Point2& a, const Point2& b) { return std::hypot(a.x - b.x, a.y - b.y); }

// Welds world positions: a point within `eps` (Chebyshev) of an earlier representative takes its id. The grid's cells
// are eps wide, so a representative within eps lies in one of the 27 cells around a point; no two representatives
// share a cell (the second would have found the first). First come, first served: deterministic in input order.
// A representative in the point's own cell lies within eps of it and is taken before the 26 around it are looked at:
// most points are a vertex seen again (every triangle around it brings it), and find it there in one lookup.
class Welder {
 public:
  explicit Welder(double eps, size_t points) : eps_(eps) {
    points_.reserve(points);
    cells_.reserve(points);
  }

  // A point's node in the map as malloc holds it: its key (24 bytes), id and next pointer (no cached hash: KeyHash
  // is noexcept) and malloc's 8-byte header, rounded up to 16.
  static constexpr size_t kNodeBytes = 48;

  uint32_t weld(const Vec3& p) {
    const std::array<int64_t, 3> c{cell(p.x), cell(p.y), cell(p.z)};
    if (const auto own = cells_.find(Key{c[0], c[1], c[2]}); own != cells_.end()) return own->second;
    for (int dz = -1; dz <= 1; ++dz) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          if (dx == 0 && dy == 0 && dz == 0) continue;  // the own cell, empty
          const auto it = cells_.find(Key{c[0] + dx, c[1] + dy, c[2] + dz});
          if (it == cells_.end()) continue;
          const Vec3& q = points_[it->second];
          if (std::abs(q.x - p.x) <= eps_ && std::abs(q.y - p.y) <= eps_ && std::abs(q.z - p.z) <= eps_) {
            return it->second;
          }
        }
      }
    }
    const auto id = static_cast<uint32_t>(points_.size());
    points_.push_back(p);
    cells_.emplace(Key{c[0], c[1], c[2]}, id);
    return id;
  }

 private:
  struct Key {
    int64_t x, y, z;
    bool operator==(const Key& o) const { return x == o.x && y == o.y && z == o.z; }
  };
  struct KeyHash {
    size_t operator()(const Key& k) const noexcept {
      uint64_t h = static_cast<uint64_t>(k.x) * 0x9E3779B97F4A7C15ull;
      h ^= static_cast<uint64_t>(k.y) + 0x632BE59BD9B4E019ull + (h << 6) + (h >> 2);
      h ^= static_cast<uint64_t>(k.z) + 0x85157AF5ull + (h << 6) + (h >> 2);
      return static_cast<size_t>(h);
    }
  };
  int64_t cell(double v) const { return static_cast<int64_t>(std::floor(v / eps_)); }

  double eps_;
  std::vector<Vec3> points_;
  std::unordered_map<Key, uint32_t, KeyHash> cells_;
};

// One side of a world edge: its welded ends (w0 < w1), the texel-space UVs at each, and where it came from.
struct EdgeSide {
  uint32_t w0, w1;
  Point2 uv0, uv1;
  TriangleRef triangle;
};

bool same_uv(const EdgeSide& a, const EdgeSide& b, double tolerance) {
  return distance(a.uv0, b.uv0) <= tolerance && distance(a.uv1, b.uv1) <= tolerance;
}

bool inside(const Point2& p, int width, int height) {
  return p.x >= 0 && p.y >= 0 && p.x <= width && p.y <= height;
}

// The seam between two sides, or why there is none.
enum class SeamCheck { seam, degenerate, outside };
SeamCheck check_seam(const Point2& a0, const Point2& a1, const Point2& b0, const Point2& b1, int width, int height) {
  if (!finite(a0) || !finite(a1) || !finite(b0) || !finite(b1)) return SeamCheck::degenerate;
  if (!inside(a0, width, height) || !inside(a1, width, height) || !inside(b0, width, height) ||
      !inside(b1, width, height)) {
    return SeamCheck::outside;
  }
  if (distance(a0, a1) < kSeamUvTolerance || distance(b0, b1) < kSeamUvTolerance) return SeamCheck::degenerate;
  return SeamCheck::seam;
}

// Calls visit(ref, world, uv) for each usable triangle of the baking instances of lightmap `name`, in scene order,
// with its world positions and texel-space UVs (lightmap_scale_offset applied), and returns how many were left out
// (no lightmap UVs, an index out of range, a non-finite value). mask_of(mesh): that mesh's per-triangle bake flags,
// or nullptr (every triangle bakes; so does one past the flags' end).
template <typename MaskOf, typename Visit>
size_t for_each_lightmap_triangle(const scene::Scene& scene, const std::string& name, int width, int height,
                                  const MaskOf& mask_of, const Visit& visit) {
  size_t skipped = 0;
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    const scene::Instance& inst = scene.instances[i];
    if (!inst.bake || scene::resolved_lightmap_name(scene, inst) != name) continue;
    if (inst.mesh < 0 || static_cast<size_t>(inst.mesh) >= scene.meshes.size()) continue;
    const scene::Mesh& mesh = scene.meshes[inst.mesh];
    const size_t triangles = mesh.indices.size() / 3;
    if (mesh.lightmap_uv.size() != mesh.positions.size()) {
      skipped += triangles;
      continue;
    }
    const std::vector<uint8_t>* mask = mask_of(static_cast<size_t>(inst.mesh));
    const auto& so = inst.lightmap_scale_offset;
    for (size_t t = 0; t < triangles; ++t) {
      if (mask && t < mask->size() && !(*mask)[t]) continue;
      std::array<Vec3, 3> world;
      std::array<Point2, 3> uv;
      bool ok = true;
      for (int k = 0; k < 3 && ok; ++k) {
        const uint32_t v = mesh.indices[3 * t + k];
        if (v >= mesh.positions.size()) {
          ok = false;
          break;
        }
        world[k] = inst.to_world.point(mesh.positions[v]);
        uv[k] = {(so[0] * mesh.lightmap_uv[v].x + so[2]) * width, (so[1] * mesh.lightmap_uv[v].y + so[3]) * height};
        ok = finite(world[k]) && finite(uv[k]);
      }
      if (!ok) {
        ++skipped;
        continue;
      }
      visit(TriangleRef{static_cast<uint32_t>(i), static_cast<uint32_t>(inst.mesh), static_cast<uint32_t>(t)}, world,
            uv);
    }
  }
  return skipped;
}

// A lightmap's byte cap: `per_texel` bytes a texel, and at least `least`.
size_t per_texel_cap(double per_texel, size_t least, uint64_t texels) {
  return std::max(least, static_cast<size_t>(per_texel * static_cast<double>(texels)));
}

// The four texels and weights of a clamp-to-edge bilinear lookup at texel-space point p.
std::array<std::pair<size_t, double>, 4> bilinear(const Point2& p, int width, int height) {
  const double x = p.x - 0.5, y = p.y - 0.5;
  const double fx0 = std::floor(x), fy0 = std::floor(y);
  const double fx = x - fx0, fy = y - fy0;
  const auto cx = [&](double v) { return static_cast<size_t>(std::clamp(v, 0.0, width - 1.0)); };
  const auto cy = [&](double v) { return static_cast<size_t>(std::clamp(v, 0.0, height - 1.0)); };
  const size_t x0 = cx(fx0), x1 = cx(fx0 + 1), y0 = cy(fy0), y1 = cy(fy0 + 1);
  const auto w = static_cast<size_t>(width);
  return {{{y0 * w + x0, (1 - fx) * (1 - fy)},
           {y0 * w + x1, fx * (1 - fy)},
           {y1 * w + x0, (1 - fx) * fy},
           {y1 * w + x1, fx * fy}}};
}

double brightness(const image::FloatImage& img, const std::vector<uint8_t>& validity) {
  double sum = 0;
  size_t n = 0;
  const int ch = img.channels;
  for (size_t t = 0; t < validity.size(); ++t) {
    if (!validity[t]) continue;
    const float* p = &img.pixels[t * ch];
    double y = 0;
    if (ch == 3) {
      y = luminance(Rgb(p[0], p[1], p[2]));
    } else {
      for (int c = 0; c < ch; ++c) y += p[c];
      y /= ch;
    }
    if (!std::isfinite(y)) continue;
    sum += y;
    ++n;
  }
  const double b = n ? sum / static_cast<double>(n) : 0.0;
  return b > 0 ? b : 1.0;
}

// The sides of the lightmap's world edges, each triangle's three (less any collapsed in world space), in scene order.
// A first pass finds the weld's scale (and how many triangles there are, to reserve the sides at once); the second
// welds. Nothing per triangle is kept between them: the positions are transformed again rather than held.
template <typename MaskOf>
std::vector<EdgeSide> edge_sides(const scene::Scene& scene, const std::string& name, int width, int height,
                                 const MaskOf& mask_of, SeamSearch& out) {
  Vec3 lo{std::numeric_limits<double>::max(), std::numeric_limits<double>::max(), std::numeric_limits<double>::max()};
  Vec3 hi = -lo;
  double largest = 0;
  size_t triangles = 0;
  out.skipped_triangles =
      for_each_lightmap_triangle(scene, name, width, height, mask_of, [&](TriangleRef, const auto& world, const auto&) {
        ++triangles;
        for (const Vec3& p : world) {
          lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
          hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
          largest = std::max({largest, std::abs(p.x), std::abs(p.y), std::abs(p.z)});
        }
      });
  std::vector<EdgeSide> sides;
  if (triangles == 0) return sides;
  // Near-exact welding: vertices split at UV seams carry bit-identical positions, but two instances (or two meshes
  // exported apart) meeting at an edge reach it through different transforms and float rounding. A millionth of
  // the lightmap's extent, or of its largest coordinate (some 16 float ulps there), covers that rounding and is far
  // below any edge a mesh models.
  const double scale = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z, largest});
  Welder welder(kWeldTolerance * scale > 0 ? kWeldTolerance * scale : std::numeric_limits<double>::min(),
                triangles);  // indexed meshes: about as many vertices as triangles, or half
  sides.reserve(3 * triangles);
  for_each_lightmap_triangle(
      scene, name, width, height, mask_of, [&](TriangleRef ref, const auto& world, const auto& uv) {
        std::array<uint32_t, 3> w{};
        for (int k = 0; k < 3; ++k) w[k] = welder.weld(world[k]);
        for (int k = 0; k < 3; ++k) {
          const int j = (k + 1) % 3;
          if (w[k] == w[j]) continue;  // a collapsed edge: no length in world space
          const bool flip = w[k] > w[j];
          sides.push_back({flip ? w[j] : w[k], flip ? w[k] : w[j], flip ? uv[j] : uv[k], flip ? uv[k] : uv[j], ref});
        }
      });
  return sides;
}

template <typename MaskOf>
SeamSearch search_seams(const scene::Scene& scene, const std::string& name, int width, int height,
                        const MaskOf& mask_of) {
  if (width < 1 || height < 1) {
    throw std::invalid_argument("find_seams: lightmap '" + name + "' must be at least 1x1 texels, got " +
                                std::to_string(width) + "x" + std::to_string(height));
  }
  SeamSearch out;
  const std::vector<EdgeSide> sides = edge_sides(scene, name, width, height, mask_of, out);
  // Group the sides by world edge; stable, so each group keeps scene order.
  std::vector<uint32_t> order(sides.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<uint32_t>(i);
  std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
    return std::tie(sides[a].w0, sides[a].w1) < std::tie(sides[b].w0, sides[b].w1);
  });
  // Each seam as its two sides, the earlier first: a group keeps scene order, so sorting the pairs puts the seams in
  // scene order of their first side, and those of one side (all in its group) in order of the second.
  std::vector<std::pair<uint32_t, uint32_t>> found;
  for (size_t i = 0; i < order.size();) {
    size_t j = i + 1;
    while (j < order.size() && sides[order[j]].w0 == sides[order[i]].w0 && sides[order[j]].w1 == sides[order[i]].w1) {
      ++j;
    }
    const size_t n = j - i;
    ++out.edges;
    if (n == 2) ++out.shared_edges;
    if (n > 2) ++out.non_manifold;
    for (size_t a = i; n <= kMostSidesOfASeamEdge && a < j; ++a) {
      for (size_t b = a + 1; b < j; ++b) {
        const EdgeSide& sa = sides[order[a]];
        const EdgeSide& sb = sides[order[b]];
        if (same_uv(sa, sb, kSeamUvTolerance)) continue;
        switch (check_seam(sa.uv0, sa.uv1, sb.uv0, sb.uv1, width, height)) {
          case SeamCheck::degenerate:
            ++out.degenerate;
            break;
          case SeamCheck::outside:
            ++out.outside;
            break;
          case SeamCheck::seam:
            found.emplace_back(order[a], order[b]);
            break;
        }
      }
    }
    i = j;
  }
  order = {};
  std::sort(found.begin(), found.end());
  out.seams.reserve(found.size());
  for (const auto& [a, b] : found) {
    out.seams.push_back({sides[a].uv0, sides[a].uv1, sides[b].uv0, sides[b].uv1, sides[a].triangle, sides[b].triangle});
  }
  return out;
}

}  // namespace

SeamSearch find_seams(const scene::Scene& scene, const std::string& name, int width, int height,
                      const std::vector<std::vector<uint8_t>>* bake_mask) {
  return search_seams(scene, name, width, height, [&](size_t mesh) -> const std::vector<uint8_t>* {
    return bake_mask && mesh < bake_mask->size() ? &(*bake_mask)[mesh] : nullptr;
  });
}

SeamSearch find_seams(const scene::CheckedScene& checked, const std::string& name, int width, int height) {
  return search_seams(checked.scene, name, width, height, [&](size_t mesh) -> const std::vector<uint8_t>* {
    return mesh < checked.triangles.size() ? &checked.triangles[mesh].bake : nullptr;
  });
}

// The sum of each stage's largest terms, per triangle: what search_seams allocates, for at most three sides (reserved
// at once) and three welded points a triangle, and kMostSeamsPerTriangle seams.
//  - welding: the sides; the welder's points (reserved at one a triangle: 6 at the reallocation from 2 to 4), its
//    map's nodes, and its buckets (a pointer each, reserved at one a triangle: 6 at the rehash from 2 to 4).
//  - grouping: the sides, the order (3 × 4 bytes) and stable_sort's buffer, half the order.
//  - pairing: the sides, the order and the pairs growing (8 bytes a seam, 3 × 8 at a reallocation).
//  - listing: the sides, the pairs (at most 2 × 8 bytes a seam, the order freed) and the seams, reserved at once.
double seam_search_bytes_per_triangle() {
  constexpr double sides = 3 * sizeof(EdgeSide), seams = kMostSeamsPerTriangle, pair = 8;
  constexpr double welding = sides + 6 * sizeof(Vec3) + 3 * Welder::kNodeBytes + 6 * sizeof(void*);
  constexpr double grouping = sides + 3 * sizeof(uint32_t) * 1.5;
  constexpr double pairing = sides + 3 * sizeof(uint32_t) + seams * 3 * pair;
  constexpr double listing = sides + seams * (2 * pair + sizeof(Seam));
  return std::max({welding, grouping, pairing, listing});
}

size_t seam_search_bytes_bound(uint64_t triangles) {
  return static_cast<size_t>(std::ceil(seam_search_bytes_per_triangle() * static_cast<double>(triangles)));
}

SeamStitcher::SeamStitcher(const std::vector<Seam>& seams, int width, int height, const std::vector<uint8_t>& validity,
                           const StitchOptions& options)
    : width_(width), height_(height), validity_(validity), options_(options) {
  if (width < 1 || height < 1 || validity.size() != static_cast<size_t>(width) * height) {
    throw std::invalid_argument("SeamStitcher: the validity map has " + std::to_string(validity.size()) +
                                " entries for a " + std::to_string(width) + "x" + std::to_string(height) +
                                " lightmap; pass the map the image was dilated from");
  }
  for (const double w : {options.seam_weight, options.valid_weight, options.dilated_weight}) {
    if (!(w > 0) || !std::isfinite(w)) {
      throw std::invalid_argument("SeamStitcher: the weights must be positive and finite");
    }
  }
  // It becomes a count of values (build_system): a negative or NaN budget has none.
  if (!(options.factor_budget >= 0) || !std::isfinite(options.factor_budget)) {
    throw std::invalid_argument("SeamStitcher: factor_budget must be finite and at least 0 (0: conjugate gradients)");
  }
  if (!(options.factor_bytes_per_texel >= 0) || !std::isfinite(options.factor_bytes_per_texel)) {
    throw std::invalid_argument(
        "SeamStitcher: factor_bytes_per_texel must be finite and at least 0 (0: conjugate gradients)");
  }
  if (!(options.lookup_bytes_per_texel >= 0) || !std::isfinite(options.lookup_bytes_per_texel)) {
    throw std::invalid_argument("SeamStitcher: lookup_bytes_per_texel must be finite and at least 0");
  }
  static_assert(kLookupPointBytes == sizeof(Pair) + 8 * sizeof(Tap));
  const size_t lookup_budget = per_texel_cap(options.lookup_bytes_per_texel, options.min_lookup_bytes, validity.size());
  // Points spaced at most half a texel on either side, ends included: segments + 1 of them (0: no lookups).
  const auto segments_of = [&](const Seam& s) {
    if (check_seam(s.a0, s.a1, s.b0, s.b1, width, height) != SeamCheck::seam) return 0;
    const double length = std::max(distance(s.a0, s.a1), distance(s.b0, s.b1));
    return std::max(1, static_cast<int>(std::ceil(2 * length)));
  };
  // Seams are taken in order while their points fit the budget; the lookups are reserved at the most those points
  // can hold (kLookupPointBytes each), so that they never grow past it.
  std::vector<uint8_t> used(seams.size(), 0);
  size_t points = 0;
  for (size_t i = 0; i < seams.size(); ++i) {
    const int segments = segments_of(seams[i]);
    if (segments == 0) continue;
    if ((points + segments + 1) * kLookupPointBytes > lookup_budget) {
      ++seams_over_budget_;
      continue;
    }
    points += segments + 1;
    used[i] = 1;
    ++seams_used_;
  }
  pairs_.reserve(points);
  taps_.reserve(8 * points);
  // Each texel's unknown, numbered in order of first use; a dense map (4 bytes a texel, allocated once per
  // lightmap, unless it has no seam) where a page's seams read millions of taps.
  constexpr uint32_t kNone = std::numeric_limits<uint32_t>::max();
  std::vector<uint32_t> unknown_of(seams_used_ == 0 ? 0 : validity.size(), kNone);
  for (size_t i = 0; i < seams.size(); ++i) {
    if (!used[i]) continue;
    const Seam& s = seams[i];
    const int segments = segments_of(s);
    for (int k = 0; k <= segments; ++k) {
      const double t = static_cast<double>(k) / segments;
      const Point2 a{s.a0.x + t * (s.a1.x - s.a0.x), s.a0.y + t * (s.a1.y - s.a0.y)};
      const Point2 b{s.b0.x + t * (s.b1.x - s.b0.x), s.b0.y + t * (s.b1.y - s.b0.y)};
      const auto first = static_cast<uint32_t>(taps_.size());
      for (int side = 0; side < 2; ++side) {
        for (const auto& [texel, w] : bilinear(side == 0 ? a : b, width, height)) {
          if (w == 0) continue;
          uint32_t& unknown = unknown_of[texel];
          if (unknown == kNone) {
            unknown = static_cast<uint32_t>(texels_.size());
            texels_.push_back(static_cast<uint32_t>(texel));
          }
          const double signed_w = side == 0 ? w : -w;
          // Merge taps of one texel (clamped lookups, or both sides reading it).
          bool merged = false;
          for (size_t q = first; q < taps_.size(); ++q) {
            if (taps_[q].unknown == unknown) {
              taps_[q].weight = static_cast<float>(taps_[q].weight + signed_w);
              merged = true;
              break;
            }
          }
          if (!merged) taps_.push_back({unknown, static_cast<float>(signed_w)});
        }
      }
      pairs_.push_back({first, static_cast<uint32_t>(taps_.size() - first)});
    }
  }
  texels_.shrink_to_fit();
  note_peak(unknown_of.capacity() * sizeof(uint32_t) + used.capacity() + seams.size() * sizeof(Seam));
  unknown_of = {};
  group_by_component();
}

// Each term is what the code allocates, in bytes per unknown u (at most one a texel), per texel t, or as the caps:
// L the lookups (reserved at kLookupPointBytes a point, at most L), F the factors (build_system keeps the factors
// and what factoring a chunk holds within F; a refactor holds at most what factoring its component did, so F more).
//  - held throughout: the validity map (t); texels_, component_start_, component_pairs_ and the factors' pointers
//    (4 + 4 + 4 + 8: at most a component an unknown); the lookups (L); the factors (F).
//  - reading the seams: the unknowns' map (4t) and texels_ growing (3 × 4u at a reallocation), beside validity, L
//    and the seams given (and a byte each: which are used).
//  - grouping by component: six maps of the unknowns (24u), component_start_ growing (12u), component_pairs_ and
//    the slots (8u), the pairs reordered (8 bytes of each point's 72: L / 9), beside validity, texels_ and L.
//  - a stitch: b, d and x0 (24u) and the channels' values before (4 × channels × u); then either build_system
//    (each component's entries, 8u, and either its tap indexes in parallel, 16u and 8 bytes a tap of a point's 64:
//    L × 8 / 9, or the chunks within F) or the solves (each thread's component, at most 65u in all: CG's diagonal
//    and four vectors, the held marks, three right-hand sides; and one refactor within F).
size_t SeamStitcher::bytes_bound(uint64_t texels, int channels, uint64_t seams, const StitchOptions& options) {
  const double t = static_cast<double>(texels), u = t;
  const auto lookups =
      static_cast<double>(per_texel_cap(options.lookup_bytes_per_texel, options.min_lookup_bytes, texels));
  const auto factors =
      static_cast<double>(per_texel_cap(options.factor_bytes_per_texel, options.min_factor_bytes, texels));
  const double held = t + 20 * u + lookups;
  const double read = t + 4 * t + 12 * u + lookups + static_cast<double>(seams) * (sizeof(Seam) + 1);
  const double grouped = t + 4 * u + 24 * u + 12 * u + 8 * u + lookups * 10 / 9;
  const double stitching = held + (24 + 4.0 * channels) * u;
  const double planned = stitching + 8 * u + std::max(16 * u + lookups * 8 / 9, factors);
  const double solved = stitching + 65 * u + 2 * factors;
  return static_cast<size_t>(std::ceil(std::max({read, grouped, planned, solved})));
}

size_t SeamStitcher::held_bytes() const {
  size_t factors = factors_.capacity() * sizeof(factors_[0]);
  for (const auto& f : factors_) factors += f ? sizeof(EnvelopeCholesky) + f->bytes() : 0;
  return validity_.capacity() +
         (texels_.capacity() + component_start_.capacity() + component_pairs_.capacity()) * sizeof(uint32_t) +
         taps_.capacity() * sizeof(Tap) + pairs_.capacity() * sizeof(Pair) + factors;
}

// Unknowns that no lookup pair links, directly or through others, are independent systems (charts of different
// instances never share a seam): numbered so that each component is a contiguous range, in order of first use, each
// keeping its own order, so that stitch() can solve them apart.
void SeamStitcher::group_by_component() {
  const size_t n = texels_.size();
  std::vector<uint32_t> parent(n);
  for (uint32_t u = 0; u < n; ++u) parent[u] = u;
  const auto root = [&](uint32_t u) {
    while (parent[u] != u) u = parent[u] = parent[parent[u]];
    return u;
  };
  for (const Pair& p : pairs_) {
    for (uint32_t i = p.first + 1; i < p.first + p.count; ++i) {
      const uint32_t a = root(taps_[p.first].unknown), b = root(taps_[i].unknown);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);  // the root is a component's first unknown
    }
  }
  std::vector<uint32_t> size_of(n, 0);
  for (uint32_t u = 0; u < n; ++u) ++size_of[root(u)];
  std::vector<uint32_t> next(n, 0);  // per root: the next new index of its component
  component_start_.assign(1, 0);
  for (uint32_t u = 0; u < n; ++u) {
    if (root(u) != u) continue;
    next[u] = component_start_.back();
    component_start_.push_back(component_start_.back() + size_of[u]);
  }
  std::vector<uint32_t> new_of(n);
  std::vector<uint32_t> texels(n);
  for (uint32_t u = 0; u < n; ++u) {
    new_of[u] = next[root(u)]++;
    texels[new_of[u]] = texels_[u];
  }
  texels_ = std::move(texels);
  for (Tap& t : taps_) t.unknown = new_of[t.unknown];
  // The pairs by component (each pair's taps are all in one), keeping their order within it: a component's matrix
  // is built from its own pairs alone (build_block).
  const size_t components = component_start_.size() - 1;
  std::vector<uint32_t> component_of(n);
  for (uint32_t k = 0; k < components; ++k) {
    std::fill(component_of.begin() + component_start_[k], component_of.begin() + component_start_[k + 1], k);
  }
  component_pairs_.assign(components + 1, 0);
  for (const Pair& p : pairs_) ++component_pairs_[component_of[taps_[p.first].unknown] + 1];
  for (size_t k = 0; k < components; ++k) component_pairs_[k + 1] += component_pairs_[k];
  std::vector<uint32_t> slot(component_pairs_.begin(), component_pairs_.end() - 1);
  std::vector<Pair> pairs(pairs_.size());
  for (const Pair& p : pairs_) pairs[slot[component_of[taps_[p.first].unknown]]++] = p;
  pairs_ = std::move(pairs);
}

// Each unknown's taps in component k, in pair order: tap[begin[u] .. begin[u + 1]) with each tap's pair.
SeamStitcher::TapIndex SeamStitcher::index_taps(size_t k) const {
  const uint32_t lo = component_start_[k], n = component_start_[k + 1] - lo;
  const uint32_t pair_lo = component_pairs_[k], pair_hi = component_pairs_[k + 1];
  TapIndex index;
  index.begin.assign(n + 1, 0);
  for (uint32_t p = pair_lo; p < pair_hi; ++p) {
    for (uint32_t t = pairs_[p].first; t < pairs_[p].first + pairs_[p].count; ++t)
      ++index.begin[taps_[t].unknown - lo + 1];
  }
  for (uint32_t u = 0; u < n; ++u) index.begin[u + 1] += index.begin[u];
  index.tap.resize(index.begin[n]);
  index.pair.resize(index.begin[n]);
  std::vector<uint32_t> next(index.begin.begin(), index.begin.end() - 1);
  for (uint32_t p = pair_lo; p < pair_hi; ++p) {
    for (uint32_t t = pairs_[p].first; t < pairs_[p].first + pairs_[p].count; ++t) {
      const uint32_t slot = next[taps_[t].unknown - lo]++;
      index.tap[slot] = t;
      index.pair[slot] = p;
    }
  }
  return index;
}

// The distinct entries of component k's matrix (both triangles, the diagonal included): how large its block is,
// known before it is built.
size_t SeamStitcher::count_entries(size_t k, const TapIndex& index) const {
  const uint32_t lo = component_start_[k], n = component_start_[k + 1] - lo;
  constexpr uint32_t kUnmarked = std::numeric_limits<uint32_t>::max();
  std::vector<uint32_t> marked_in(n, kUnmarked);  // per column: the last row that counted it
  size_t entries = 0;
  for (uint32_t r = 0; r < n; ++r) {
    marked_in[r] = r;  // the diagonal
    ++entries;
    for (uint32_t e = index.begin[r]; e < index.begin[r + 1]; ++e) {
      const Pair& p = pairs_[index.pair[e]];
      for (uint32_t j = p.first; j < p.first + p.count; ++j) {
        uint32_t& mark = marked_in[taps_[j].unknown - lo];
        if (mark == r) continue;
        mark = r;
        ++entries;
      }
    }
  }
  return entries;
}

// What building and factoring a component of n unknowns, `taps` taps and `entries` matrix entries holds beside its
// factor's values: the index of its taps with the marks that count the entries, its block (reserved exactly), and
// the factor's rows and working space.
size_t SeamStitcher::factoring_bytes(size_t n, size_t taps, size_t entries) {
  const size_t index = (n + 1 + 2 * taps + 2 * n) * sizeof(uint32_t);  // begin, tap, pair; next or the marks
  const size_t block = (n + 1 + entries) * sizeof(uint32_t) + (entries + n) * sizeof(double);
  return index + block + sizeof(EnvelopeCholesky) + EnvelopeCholesky::bytes_for(n, 0) +
         n * EnvelopeCholesky::kWorkBytesPerRow;
}

// The normal matrix's entries are the products of each lookup pair's taps and each unknown's own weight. Row r is
// summed from the pairs that read unknown r, in pair order, its own weight last, and ordered by column: the same
// matrix on every run. Built a component at a time, in its own numbering (row and column i is unknown lo + i), so
// that only the components CG solves keep theirs. `index` and `entries`: index_taps(k) and count_entries of it.
SeamStitcher::Block SeamStitcher::build_block(size_t k, const TapIndex& index, size_t entries) const {
  const uint32_t lo = component_start_[k], n = component_start_[k + 1] - lo;
  Block b;
  b.row_start.assign(n + 1, 0);
  b.diagonal.assign(n, 0.0);
  b.col.reserve(entries);
  b.value.reserve(entries);
  std::vector<std::pair<uint32_t, double>> row;  // (column, sum) in order of first contribution
  const auto add = [&row](uint32_t c, double v) {
    for (auto& [col, sum] : row) {
      if (col == c) {
        sum += v;
        return;
      }
    }
    row.push_back({c, 0.0});
    row.back().second += v;  // 0 + v, as every sum starts
  };
  for (uint32_t r = 0; r < n; ++r) {
    row.clear();
    for (uint32_t e = index.begin[r]; e < index.begin[r + 1]; ++e) {
      const Tap& mine = taps_[index.tap[e]];
      const Pair& p = pairs_[index.pair[e]];
      for (uint32_t j = p.first; j < p.first + p.count; ++j) {
        add(taps_[j].unknown - lo, options_.seam_weight * mine.weight * taps_[j].weight);
      }
    }
    add(r, texel_weight(lo + r));
    std::sort(row.begin(), row.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    for (const auto& [c, sum] : row) {
      if (c == r) b.diagonal[r] = sum;
      b.col.push_back(c);
      b.value.push_back(sum);
    }
    b.row_start[r + 1] = static_cast<uint32_t>(b.col.size());
  }
  return b;
}

size_t SeamStitcher::taps_of(size_t k) const {
  size_t taps = 0;
  for (uint32_t p = component_pairs_[k]; p < component_pairs_[k + 1]; ++p) taps += pairs_[p].count;
  return taps;
}

size_t SeamStitcher::Block::bytes() const {
  return (row_start.capacity() + col.capacity()) * sizeof(uint32_t) +
         (value.capacity() + diagonal.capacity()) * sizeof(double);
}

size_t SeamStitcher::max_factor_bytes() const {
  return per_texel_cap(options_.factor_bytes_per_texel, options_.min_factor_bytes, validity_.size());
}

// Each component's matrix, factored within its budget and dropped. What factoring a component holds (its block, its
// factor at the most values allowed, their working space) is known before its block is built (count_entries), so
// components are taken in order into chunks of at most kChunk whose reservations fit beside the factors kept, and a
// chunk is factored in parallel: the factors kept and everything a chunk holds while it is factored stay within
// max_factor_bytes, on any number of threads. A component whose reservation does not fit what is left goes alone, its
// factor allowed what is left (not factored if that is too little). The same components are factored on every run;
// the rest are solved by CG from the lookups. Refactoring a component with values held at 0 (solve_component) holds
// what factoring it did, so at most max_factor_bytes beside the factors kept.
void SeamStitcher::build_system(size_t beside) {
  if (system_built_) return;
  constexpr size_t kChunk = 16;
  const size_t components = component_start_.size() - 1;
  const size_t max_bytes = max_factor_bytes();
  std::vector<size_t> entries(components);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, components), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t k = range.begin(); k < range.end(); ++k) entries[k] = count_entries(k, index_taps(k));
  });
  note_peak(beside + entries.capacity() * sizeof(size_t));
  factors_.resize(components);
  size_t kept = 0;  // the factors' bytes, as held_bytes counts them
  for (size_t k = 0; k < components;) {
    std::vector<std::pair<size_t, size_t>> chunk;  // (component, the most values its factor may hold)
    size_t reserved = 0;
    for (; k < components && chunk.size() < kChunk; ++k) {
      const uint32_t n = component_start_[k + 1] - component_start_[k];
      const size_t fixed = factoring_bytes(n, taps_of(k), entries[k]);
      const size_t left = max_bytes - std::min(max_bytes, kept + reserved);
      const auto wanted = static_cast<size_t>(options_.factor_budget * static_cast<double>(entries[k]));
      const size_t allowed = left > fixed ? std::min(wanted, (left - fixed) / sizeof(double)) : 0;
      if (allowed < wanted && !chunk.empty()) break;  // alone in the next chunk, with all that is left then
      if (allowed < n) continue;                      // its factor cannot hold even the diagonal: CG
      chunk.push_back({k, allowed});
      reserved += fixed + allowed * sizeof(double);
    }
    tbb::parallel_for(tbb::blocked_range<size_t>(0, chunk.size()), [&](const tbb::blocked_range<size_t>& range) {
      for (size_t c = range.begin(); c < range.end(); ++c) {
        const auto [j, allowed] = chunk[c];
        const Block b = build_block(j, index_taps(j), entries[j]);
        auto f = std::make_unique<EnvelopeCholesky>();
        const uint32_t n = component_start_[j + 1] - component_start_[j];
        if (f->factor({b.row_start, b.col, b.value, 0, n}, allowed)) factors_[j] = std::move(f);
      }
    });
    note_peak(beside + entries.capacity() * sizeof(size_t) + reserved);
    for (const auto& [j, allowed] : chunk) {
      if (factors_[j]) kept += sizeof(EnvelopeCholesky) + factors_[j]->bytes();
    }
  }
  system_built_ = true;
}

size_t SeamStitcher::factor_bytes() const {
  size_t bytes = 0;
  for (const auto& f : factors_) bytes += f ? f->bytes() : 0;
  return bytes;
}

size_t SeamStitcher::factored_components() const {
  size_t n = 0;
  for (size_t k = 0; k < factors_.size(); ++k) n += factored(k);
  return n;
}

StitchStats SeamStitcher::measure(const image::FloatImage& image) const {
  if (image.width != width_ || image.height != height_ || image.channels < 1) {
    throw std::invalid_argument("SeamStitcher: the image is " + std::to_string(image.width) + "x" +
                                std::to_string(image.height) + ", the seams were found for " +
                                std::to_string(width_) + "x" + std::to_string(height_));
  }
  StitchStats s;
  s.unknowns = texels_.size();
  s.samples = pairs_.size();
  s.components = components();
  s.factored = factored_components();
  mismatch(image, brightness(image, validity_), s.mismatch_before, s.rms_before);
  return s;
}

void SeamStitcher::mismatch(const image::FloatImage& image, double scale, double& largest, double& rms) const {
  const int ch = image.channels;
  largest = 0;
  double sum_sq = 0;
  size_t counted = 0;
  for (const Pair& p : pairs_) {
    for (int c = 0; c < ch; ++c) {
      double r = 0;
      for (uint32_t i = p.first; i < p.first + p.count; ++i) {
        r += taps_[i].weight * image.pixels[static_cast<size_t>(texels_[taps_[i].unknown]) * ch + c];
      }
      const double m = std::abs(r) / scale;
      if (!std::isfinite(m)) continue;
      largest = std::max(largest, m);
      sum_sq += m * m;
      ++counted;
    }
  }
  rms = counted ? std::sqrt(sum_sq / static_cast<double>(counted)) : 0.0;
}

void SeamStitcher::multiply(size_t k, const uint8_t* held, const double* p, double* q) const {
  const uint32_t lo = component_start_[k], n = component_start_[k + 1] - lo;
  for (uint32_t i = 0; i < n; ++i) {
    q[i] = texel_weight(lo + i) * p[i];
  }
  for (uint32_t pair = component_pairs_[k]; pair < component_pairs_[k + 1]; ++pair) {
    const Pair& pr = pairs_[pair];
    double rp = 0;
    for (uint32_t t = pr.first; t < pr.first + pr.count; ++t) {
      const uint32_t i = taps_[t].unknown - lo;
      if (!held || !held[i]) rp += taps_[t].weight * p[i];
    }
    for (uint32_t t = pr.first; t < pr.first + pr.count; ++t) {
      q[taps_[t].unknown - lo] += options_.seam_weight * taps_[t].weight * rp;
    }
  }
  if (!held) return;
  for (uint32_t i = 0; i < n; ++i) {
    if (held[i]) q[i] = 0;
  }
}

// Preconditioned conjugate gradients from d = 0 (Jacobi: the diagonal is at least a texel's c_i > 0), to
// ‖r‖ ≤ tolerance · ‖b‖. Held unknowns take no part: their residual and direction stay 0. Returns the iterations;
// `converged` says whether the tolerance was reached.
int SeamStitcher::conjugate_gradients(size_t k, const double* b, const uint8_t* held, double* d,
                                      bool& converged) const {
  const uint32_t lo = component_start_[k], n = component_start_[k + 1] - lo;
  const auto free = [held](uint32_t i) { return !held || !held[i]; };
  // The diagonal: c_i + w_seam Σ_k r_ki² (each pair has one tap per unknown).
  std::vector<double> diagonal(n);
  for (uint32_t i = 0; i < n; ++i) {
    diagonal[i] = texel_weight(lo + i);
  }
  for (uint32_t pair = component_pairs_[k]; pair < component_pairs_[k + 1]; ++pair) {
    for (uint32_t t = pairs_[pair].first; t < pairs_[pair].first + pairs_[pair].count; ++t) {
      diagonal[taps_[t].unknown - lo] += options_.seam_weight * taps_[t].weight * taps_[t].weight;
    }
  }
  std::vector<double> r(n), z(n), p(n), q(n);
  for (uint32_t i = 0; i < n; ++i) r[i] = free(i) ? b[i] : 0.0;
  const auto dot = [](const std::vector<double>& x, const std::vector<double>& y) {
    double sum = 0;
    for (size_t i = 0; i < x.size(); ++i) sum += x[i] * y[i];
    return sum;
  };
  for (uint32_t i = 0; i < n; ++i) {
    if (free(i)) d[i] = 0;
  }
  const double b_norm = std::sqrt(dot(r, r));
  converged = true;
  if (!(b_norm > 0)) return 0;  // the lookups already agree exactly
  for (uint32_t i = 0; i < n; ++i) p[i] = z[i] = r[i] / diagonal[i];
  double rz = dot(r, z);
  int it = 0;
  for (; it < options_.max_iterations; ++it) {
    if (std::sqrt(dot(r, r)) <= options_.tolerance * b_norm) return it;
    multiply(k, held, p.data(), q.data());
    const double pq = dot(p, q);
    if (!(pq > 0)) break;  // numerically exhausted
    const double alpha = rz / pq;
    for (uint32_t i = 0; i < n; ++i) {
      if (!free(i)) continue;
      d[i] += alpha * p[i];
      r[i] -= alpha * q[i];
      z[i] = r[i] / diagonal[i];
    }
    const double rz_next = dot(r, z);
    const double beta = rz_next / rz;
    rz = rz_next;
    for (uint32_t i = 0; i < n; ++i) p[i] = z[i] + beta * p[i];
  }
  converged = std::sqrt(dot(r, r)) <= options_.tolerance * b_norm;
  return it;
}

namespace {

// Fixes the change of each held unknown i at d_i = −x⁰_i (its value at 0) in the system a d = rhs: its row becomes
// d_i = −x⁰_i and its column moves to the right-hand side of the other rows. The matrix stays symmetric positive
// definite with the same pattern (entries set to 0 stay), so it factors like the original.
template <class Block>
void hold_at_zero(Block& a, const std::vector<uint8_t>& held, const double* x0, std::vector<double>& rhs) {
  const size_t n = held.size();
  for (size_t r = 0; r < n; ++r) {
    for (uint32_t e = a.row_start[r]; e < a.row_start[r + 1]; ++e) {
      const uint32_t c = a.col[e];
      if (held[r]) {
        a.value[e] = c == r ? 1.0 : 0.0;
      } else if (held[c]) {
        rhs[r] -= a.value[e] * -x0[c];
        a.value[e] = 0;
      }
    }
    if (held[r]) {
      a.diagonal[r] = 1;
      rhs[r] = -x0[r];
    }
  }
}

}  // namespace

// Lets refactors run together while what they may hold fits a capacity; one alone always runs (it fits: build_system
// allowed its component that much).
class SeamStitcher::RefactorGate {
 public:
  explicit RefactorGate(size_t capacity) : capacity_(capacity) {}
  void enter(size_t bytes) {
    std::unique_lock<std::mutex> lock(mutex_);
    room_.wait(lock, [&] { return in_use_ == 0 || in_use_ + bytes <= capacity_; });
    in_use_ += bytes;
  }
  void leave(size_t bytes) {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      in_use_ -= bytes;
    }
    room_.notify_all();
  }

 private:
  size_t capacity_, in_use_ = 0;
  std::mutex mutex_;
  std::condition_variable room_;
};

// The most refactoring factored component k holds: its factor again, and what factoring it held, its block's entries
// taken at their most (the envelope holds the lower triangle and the diagonal, so at most 2 · entries − n of them).
size_t SeamStitcher::refactor_reservation(size_t k) const {
  const EnvelopeCholesky& f = *factors_[k];
  return factoring_bytes(f.size(), taps_of(k), 2 * f.entries() - f.size()) + f.bytes();
}

// Irradiance, radiance and AO are never negative, but the least-squares fit can take a texel below 0: a dilated
// texel beside a seam whose sides see very different light (a lit top against a side in shadow, a sampled chart
// against one a time limit left black) pulls its lookup toward the dark side the cheapest way, through the texel the
// lookup weighs least. Clamping those values afterwards would undo the agreement the fit bought. Instead each unknown
// the fit takes below 0 is held at 0 and the component solved again for the others, until none goes below: an active
// set that only grows. That is not the exact non-negative least squares (which may release a held unknown), but every
// value is ≥ 0 and the others still make the lookups agree, since any values ≥ 0 equal along a seam satisfy it. Each
// round holds at least one more unknown; past kHoldRounds the remaining negatives are clamped in stitch().
SeamStitcher::ComponentSolve SeamStitcher::solve_component(size_t k, const std::vector<double>& x0, bool non_negative,
                                                           const std::vector<double>& b, std::vector<double>& d,
                                                           RefactorGate& gate) const {
  constexpr int kHoldRounds = 16;
  const uint32_t lo = component_start_[k], hi = component_start_[k + 1], n = hi - lo;
  ComponentSolve out;
  const size_t cg_bytes = 5 * static_cast<size_t>(n) * sizeof(double);  // its diagonal, r, z, p and q
  if (factored(k)) {
    std::copy(b.begin() + lo, b.begin() + hi, d.begin() + lo);
    factors_[k]->solve(&d[lo]);
  } else {
    out.iterations = conjugate_gradients(k, &b[lo], nullptr, &d[lo], out.converged);
    out.bytes = cg_bytes;
  }
  if (!non_negative) return out;
  std::vector<uint8_t> held;  // per unknown of the component, once one goes below 0
  for (int round = 0; round < kHoldRounds; ++round) {
    size_t newly = 0;
    for (uint32_t i = 0; i < n; ++i) {
      if (x0[lo + i] + d[lo + i] >= 0 || (!held.empty() && held[i])) continue;
      if (held.empty()) held.assign(n, 0);
      held[i] = 1;
      d[lo + i] = -x0[lo + i];  // exactly 0 once added back
      ++newly;
    }
    if (newly == 0) break;
    out.held_at_zero += newly;
    std::vector<double> rhs(b.begin() + lo, b.begin() + hi);
    out.bytes = std::max(out.bytes, held.capacity() + rhs.capacity() * sizeof(double));
    if (factored(k)) {
      // A refactor's block and factor (the same envelope as the factor kept, which build_system allowed with its
      // block) are the stitch's largest transient: refactors run together only while they fit the factor cap.
      bool solved = false;
      const size_t may_hold = refactor_reservation(k);
      gate.enter(may_hold);
      {
        const TapIndex index = index_taps(k);
        Block a = build_block(k, index, count_entries(k, index));
        hold_at_zero(a, held, &x0[lo], rhs);
        EnvelopeCholesky f;
        solved = f.factor({a.row_start, a.col, a.value, 0, n}, factors_[k]->entries());
        out.refactor_bytes = std::max(out.refactor_bytes, a.bytes() + f.bytes());
        if (solved) {
          std::copy(rhs.begin(), rhs.end(), d.begin() + lo);
          f.solve(&d[lo]);
        }
      }
      gate.leave(may_hold);
      if (solved) continue;
      rhs.assign(b.begin() + lo, b.begin() + hi);
    }
    // The held unknowns' fixed change, moved to the right-hand side: rhs −= A d_held.
    std::vector<double> fixed(n, 0.0), moved(n);
    for (uint32_t i = 0; i < n; ++i) {
      if (held[i]) fixed[i] = d[lo + i];
    }
    multiply(k, nullptr, fixed.data(), moved.data());
    for (uint32_t i = 0; i < n; ++i) rhs[i] -= moved[i];
    bool converged = true;
    out.iterations = std::max(out.iterations, conjugate_gradients(k, rhs.data(), held.data(), &d[lo], converged));
    out.converged = out.converged && converged;
    out.bytes = std::max(out.bytes, cg_bytes + held.capacity() + 3 * rhs.capacity() * sizeof(double));
  }
  return out;
}

// The component solves of one channel, summed: the figures StitchStats reports, and the most bytes the solves can
// have held at once: the `threads` largest, and the `threads` largest refactors up to the gate's capacity. The same
// whichever thread solved what.
SeamStitcher::SolveSummary::SolveSummary(size_t threads) : largest(threads, 0), largest_refactors(threads, 0) {}

void SeamStitcher::SolveSummary::add(const ComponentSolve& one) {
  iterations = std::max(iterations, one.iterations);
  converged = converged && one.converged;
  held_at_zero += one.held_at_zero;
  keep(largest, one.bytes);
  keep(largest_refactors, one.refactor_bytes);
}

void SeamStitcher::SolveSummary::merge(const SolveSummary& other) {
  iterations = std::max(iterations, other.iterations);
  converged = converged && other.converged;
  held_at_zero += other.held_at_zero;
  for (const size_t bytes : other.largest) keep(largest, bytes);
  for (const size_t bytes : other.largest_refactors) keep(largest_refactors, bytes);
}

// `list` stays sorted, largest first, and as long as it began.
void SeamStitcher::SolveSummary::keep(std::vector<size_t>& list, size_t bytes) {
  const auto at = std::upper_bound(list.begin(), list.end(), bytes, std::greater<>());
  if (at == list.end()) return;
  list.insert(at, bytes);
  list.pop_back();
}

size_t SeamStitcher::SolveSummary::bytes_at_once(size_t refactor_capacity) const {
  const size_t refactors = std::accumulate(largest_refactors.begin(), largest_refactors.end(), size_t{0});
  return std::accumulate(largest.begin(), largest.end(), std::min(refactors, refactor_capacity));
}

StitchStats SeamStitcher::stitch(image::FloatImage& image) {
  const auto t0 = std::chrono::steady_clock::now();
  StitchStats s = measure(image);
  const double scale = brightness(image, validity_);
  const size_t n = texels_.size();
  const int ch = image.channels;
  std::vector<float> before(n * ch);
  for (size_t u = 0; u < n; ++u) {
    for (int c = 0; c < ch; ++c) before[u * ch + c] = image.pixels[static_cast<size_t>(texels_[u]) * ch + c];
  }
  std::vector<double> b(n), d(n), x0(n);
  const size_t components = component_start_.size() - 1;
  RefactorGate gate(max_factor_bytes());
  // Each thread solves one component at a time, and refactors run together only while they fit the factor cap
  // (RefactorGate): what the solves hold at once is counted by SolveSummary::bytes_at_once.
  const auto threads = static_cast<size_t>(std::max(1, tbb::this_task_arena::max_concurrency()));
  // The stitch's own vectors, beside what the stitcher holds.
  const size_t vector_bytes = (b.capacity() + d.capacity() + x0.capacity()) * sizeof(double) +
                              before.capacity() * sizeof(float) + 2 * (threads + 1) * threads * sizeof(size_t);
  note_peak(vector_bytes);
  for (int c = 0; c < ch && n > 0; ++c) {
    bool finite_values = true, non_negative = true;
    for (size_t u = 0; u < n; ++u) {
      x0[u] = image.pixels[static_cast<size_t>(texels_[u]) * ch + c];
      finite_values = finite_values && std::isfinite(x0[u]);
      non_negative = non_negative && x0[u] >= 0;
    }
    if (!finite_values) {
      ++s.channels_skipped;
      continue;
    }
    // b = −Σ_k w r_k (r_k · x⁰)
    std::fill(b.begin(), b.end(), 0.0);
    for (const Pair& pair : pairs_) {
      double rx = 0;
      for (uint32_t i = pair.first; i < pair.first + pair.count; ++i) rx += taps_[i].weight * x0[taps_[i].unknown];
      for (uint32_t i = pair.first; i < pair.first + pair.count; ++i) {
        b[taps_[i].unknown] -= options_.seam_weight * taps_[i].weight * rx;
      }
    }
    // Lookups that agree already (every value 0, as on a page left unsampled) leave nothing to solve.
    if (std::all_of(b.begin(), b.end(), [](double x) { return x == 0; })) continue;
    build_system(vector_bytes);
    // Each component on its own (they share no unknown): the result does not depend on the threads.
    tbb::combinable<SolveSummary> summaries([threads] { return SolveSummary(threads); });
    tbb::parallel_for(tbb::blocked_range<size_t>(0, components), [&](const tbb::blocked_range<size_t>& range) {
      SolveSummary& mine = summaries.local();
      for (size_t k = range.begin(); k < range.end(); ++k) {
        mine.add(solve_component(k, x0, non_negative, b, d, gate));
      }
    });
    SolveSummary all(threads);
    summaries.combine_each([&all](const SolveSummary& one) { all.merge(one); });
    s.iterations = std::max(s.iterations, all.iterations);
    s.converged = s.converged && all.converged;
    s.held_at_zero += all.held_at_zero;
    note_peak(vector_bytes + all.bytes_at_once(max_factor_bytes()));
    constexpr double kMax = std::numeric_limits<float>::max();
    for (size_t u = 0; u < n; ++u) {
      const double value = x0[u] + d[u];
      if (!std::isfinite(value)) continue;  // cannot happen for finite inputs; never write a NaN
      // Never below 0 where no value was (solve_component holds them; this only after its last round).
      const double lo = non_negative ? 0.0 : -kMax;
      image.pixels[static_cast<size_t>(texels_[u]) * ch + c] = static_cast<float>(std::clamp(value, lo, kMax));
    }
  }
  for (size_t u = 0; u < n; ++u) {
    const float* now = &image.pixels[static_cast<size_t>(texels_[u]) * ch];
    if (std::memcmp(now, &before[u * ch], sizeof(float) * ch) != 0) ++s.texels_changed;
  }
  mismatch(image, scale, s.mismatch_after, s.rms_after);
  s.factored = factored_components();
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return s;
}

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The seams as the stitcher takes them, with the search's counts noted in `report` on the way.
std::vector<Seam> found_seams(const scene::CheckedScene& checked, const std::string& name, int width, int height,
                              SeamReport& report) {
  SeamSearch found = find_seams(checked, name, width, height);
  report.seams = found.seams.size();
  report.non_manifold = found.non_manifold;
  report.left_out = found.degenerate + found.outside;
  return std::move(found.seams);
}

}  // namespace

LightmapSeams::LightmapSeams(const scene::CheckedScene& checked, const std::string& name, int width, int height,
                             const std::vector<uint8_t>& validity, const StitchOptions& options)
    : stitcher_([&] {
        const auto t0 = std::chrono::steady_clock::now();
        std::vector<Seam> seams = found_seams(checked, name, width, height, report_);
        SeamStitcher s(seams, width, height, validity, options);
        report_.seconds += seconds_since(t0);
        return s;
      }()) {
  report_.samples = stitcher_.samples();
  report_.over_budget = stitcher_.seams_over_budget();
  report_.components = stitcher_.components();
  report_.peak_bytes = stitcher_.peak_bytes();
}

void LightmapSeams::stitch(image::FloatImage& image, bool irradiance) {
  const StitchStats s = stitcher_.stitch(image);
  report_.seconds += s.seconds;
  report_.factored = s.factored;
  report_.peak_bytes = stitcher_.peak_bytes();
  if (!irradiance) return;
  report_.texels_changed = s.texels_changed;
  report_.held_at_zero = s.held_at_zero;
  report_.mismatch_before = s.mismatch_before;
  report_.mismatch_after = s.mismatch_after;
  report_.rms_before = s.rms_before;
  report_.rms_after = s.rms_after;
  report_.iterations = s.iterations;
  report_.converged = s.converged;
}

}  // namespace kiln::lightmap
