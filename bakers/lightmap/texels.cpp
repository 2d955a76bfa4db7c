#include "bakers/lightmap/texels.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "bakers/scene/scene_check.h"

namespace kiln::lightmap {
namespace {

constexpr double cross2(Point2 a, Point2 b) { return a.x * b.y - a.y * b.x; }
constexpr Point2 sub(Point2 a, Point2 b) { return {a.x - b.x, a.y - b.y}; }

// A convex polygon of at most 7 vertices: a triangle clipped by four half-planes gains at most one vertex per plane.
struct Polygon {
  std::array<Point2, 7> v;
  int n = 0;
};

// Sutherland–Hodgman against one axis-aligned half-plane: keeps coord(p) ≥ bound (sign = +1) or ≤ bound (sign = −1).
template <int kAxis>
void clip_half_plane(const Polygon& in, Polygon& out, double bound, double sign) {
  const auto coord = [](Point2 p) { return kAxis == 0 ? p.x : p.y; };
  out.n = 0;
  Point2 a = in.v[in.n - 1];
  double da = sign * (coord(a) - bound);
  for (int i = 0; i < in.n; ++i) {
    const Point2 b = in.v[i];
    const double db = sign * (coord(b) - bound);
    if ((da >= 0) != (db >= 0)) {
      // The edge a→b crosses the boundary; da − db ≠ 0 since they have different signs. The crossing's own
      // coordinate is set exactly to the bound so that points on the texel border are exactly on it.
      const double t = da / (da - db);
      Point2 p{a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)};
      (kAxis == 0 ? p.x : p.y) = bound;
      out.v[out.n++] = p;
    }
    if (db >= 0) out.v[out.n++] = b;
    a = b;
    da = db;
  }
}

// The triangle (in coordinates relative to the texel's corner) clipped to the unit square. Sides the triangle does
// not cross are skipped: most small triangles cross one or two.
Polygon clip_to_unit_square(Point2 a, Point2 b, Point2 c) {
  Polygon p, q;
  p.v[0] = a, p.v[1] = b, p.v[2] = c, p.n = 3;
  const double lo_x = std::min({a.x, b.x, c.x}), hi_x = std::max({a.x, b.x, c.x});
  const double lo_y = std::min({a.y, b.y, c.y}), hi_y = std::max({a.y, b.y, c.y});
  if (lo_x < 0) clip_half_plane<0>(p, q, 0.0, +1.0), std::swap(p, q);
  if (p.n > 0 && hi_x > 1) clip_half_plane<0>(p, q, 1.0, -1.0), std::swap(p, q);
  if (p.n > 0 && lo_y < 0) clip_half_plane<1>(p, q, 0.0, +1.0), std::swap(p, q);
  if (p.n > 0 && hi_y > 1) clip_half_plane<1>(p, q, 1.0, -1.0), std::swap(p, q);
  return p;
}

double area(const Polygon& p) {
  double twice = 0;
  for (int i = 0; i < p.n; ++i) twice += cross2(p.v[i], p.v[(i + 1) % p.n]);
  return 0.5 * std::fabs(twice);
}

// Barycentrics (b0, b1, b2) of q in triangle (a, b, c) with twice-signed-area d = (b − a) × (c − a) ≠ 0; works for
// either winding.
std::array<double, 3> barycentric(Point2 q, Point2 a, Point2 b, Point2 c, double d) {
  const double b1 = cross2(sub(q, a), sub(c, a)) / d;
  const double b2 = cross2(sub(b, a), sub(q, a)) / d;
  return {1.0 - b1 - b2, b1, b2};
}

// Snaps barycentrics computed for a point of the triangle onto it: rounding can leave one a few ulps below 0.
std::array<double, 3> clamp_barycentric(std::array<double, 3> b) {
  for (double& x : b) x = std::clamp(x, 0.0, 1.0);
  // They summed to 1, so the largest was ≥ 1/3 and stays ≥ 1/3 after clamping: the sum is never 0.
  const double sum = b[0] + b[1] + b[2];
  for (double& x : b) x /= sum;
  return b;
}

bool finite(Point2 p) { return std::isfinite(p.x) && std::isfinite(p.y); }

// The linear part of an instance transform, as needed for normals: M^{-T} n ∝ sign(det M) · cof(M) n, where
// cof(M) = det(M) M^{-T} is the cofactor matrix (defined even when M is singular, where det = 0 flags it).
struct NormalTransform {
  std::array<double, 9> cof{};
  double det = 0;

  explicit NormalTransform(const scene::Transform& t) {
    const auto& m = t.m;
    const double a = m[0], b = m[1], c = m[2], d = m[4], e = m[5], f = m[6], g = m[8], h = m[9], i = m[10];
    cof = {e * i - f * h, f * g - d * i, d * h - e * g,  //
           c * h - b * i, a * i - c * g, b * g - a * h,  //
           b * f - c * e, c * d - a * f, a * e - b * d};
    det = a * cof[0] + b * cof[1] + c * cof[2];
  }
  // Unnormalised normal direction on the front side (the sign of det flips mirrored instances back).
  Vec3 apply(const Vec3& n) const {
    const double s = det < 0 ? -1.0 : 1.0;
    return Vec3{cof[0] * n.x + cof[1] * n.y + cof[2] * n.z, cof[3] * n.x + cof[4] * n.y + cof[5] * n.z,
                cof[6] * n.x + cof[7] * n.y + cof[8] * n.z} *
           s;
  }
};

// What the samples of one triangle share, computed once per triangle.
struct WorldTriangle {
  std::array<Vec3, 3> p;  // world positions
  Vec3 ng;                // unit front normal
  std::array<Vec3, 3> n;  // unit vertex normals (world), when normals_ok
  TriangleRef ref;
  float texel_size = 0;
  float ray_offset = 0;
  bool normals_ok = false;

  TexelSample sample(const std::array<double, 3>& b, double weight) const {
    TexelSample s;
    s.position = p[0] * b[0] + p[1] * b[1] + p[2] * b[2];
    s.geometric_normal = ng;
    s.shading_normal = ng;
    if (normals_ok) {
      const Vec3 v = n[0] * b[0] + n[1] * b[1] + n[2] * b[2];
      const double len = length(v);
      // Opposite vertex normals can cancel; the geometric normal is then the only direction there is.
      if (len > 0 && is_finite(v / len)) s.shading_normal = v / len;
    }
    s.barycentric = {b[1], b[2]};
    s.weight = weight;
    s.triangle = ref;
    s.texel_world_size = texel_size;
    s.ray_offset = ray_offset;
    return s;
  }
};

// A sample before it is placed: compact, so that sorting by texel moves little memory. `world` indexes its block's
// WorldTriangles.
struct Fragment {
  uint32_t texel;
  uint32_t world;
  double b1, b2;  // barycentrics, clamped onto the triangle
  double weight;
};

// One instance's share of the work: its mesh and the per-instance constants.
struct InstanceJob {
  uint32_t instance = 0, mesh = 0;
  size_t first_triangle = 0;  // position of its first triangle in the global sequence
  size_t triangles = 0;
  NormalTransform normal_transform{scene::Transform{}};
  bool normals_usable = false;                     // one normal per position
  std::array<double, 4> scale_offset{1, 1, 0, 0};  // Instance::lightmap_scale_offset
  const std::vector<uint8_t>* mask = nullptr;      // RasterOptions::bake_mask for this mesh, if any
};

struct BlockResult {
  std::vector<Fragment> fragments;
  std::vector<WorldTriangle> triangles;  // of the triangles that covered a texel
  RasterReport report;
};

void note_skip(RasterReport& report, const TriangleRef& ref, SkipReason reason) {
  ++report.skipped[static_cast<int>(reason)];
  if (report.skipped_examples.size() < RasterReport::kMaxSkippedExamples) {
    report.skipped_examples.push_back({ref, reason});
  }
}

// The texel-space box a triangle's UVs span, clamped to the lightmap: texels [x0, x1] × [y0, y1] (empty when
// x0 > x1 or y0 > y1).
struct TexelRange {
  int x0, y0, x1, y1;
};

TexelRange texel_range(const std::array<Point2, 3>& uv, int w, int h) {
  const double lo_x = std::min({uv[0].x, uv[1].x, uv[2].x}), hi_x = std::max({uv[0].x, uv[1].x, uv[2].x});
  const double lo_y = std::min({uv[0].y, uv[1].y, uv[2].y}), hi_y = std::max({uv[0].y, uv[1].y, uv[2].y});
  // (Clamped to [−1, size + 1] before the conversion: UVs far outside must not overflow an int.)
  const auto clamp_to = [](double v, int size) { return std::clamp(v, -1.0, size + 1.0); };
  return {std::max(0, static_cast<int>(std::floor(clamp_to(lo_x, w)))),
          std::max(0, static_cast<int>(std::floor(clamp_to(lo_y, h)))),
          std::min(w - 1, static_cast<int>(std::ceil(clamp_to(hi_x, w))) - 1),
          std::min(h - 1, static_cast<int>(std::ceil(clamp_to(hi_y, h))) - 1)};
}

enum class Coverage { none, partial, whole };

// How triangle (a, b, c), relative to a texel's corner, covers the unit square, from its edge functions at the four
// corners: all corners outside one edge (≤ 0: an edge contact has no area) is none, all inside every edge is the
// whole texel; anything else needs a clip. `orientation` is the sign of the triangle's UV area.
Coverage corner_coverage(Point2 a, Point2 b, Point2 c, double orientation) {
  bool whole = true;
  for (int e = 0; e < 3; ++e) {
    const Point2 from = e == 0 ? a : e == 1 ? b : c, to = e == 0 ? b : e == 1 ? c : a;
    const Point2 edge = sub(to, from);
    int inside_corners = 0, outside_corners = 0;
    for (const Point2 q : {Point2{0, 0}, Point2{1, 0}, Point2{0, 1}, Point2{1, 1}}) {
      const double f = orientation * cross2(edge, sub(q, from));
      inside_corners += f >= 0 ? 1 : 0;
      outside_corners += f <= 0 ? 1 : 0;
    }
    if (outside_corners == 4) return Coverage::none;
    whole = whole && inside_corners == 4;
  }
  return whole ? Coverage::whole : Coverage::partial;
}

// The mean of a polygon's vertices: inside it when it is convex.
Point2 vertex_mean(const Polygon& p) {
  Point2 mean{0, 0};
  for (int m = 0; m < p.n; ++m) mean = {mean.x + p.v[m].x, mean.y + p.v[m].y};
  return {mean.x / p.n, mean.y / p.n};
}

class Rasterizer {
 public:
  Rasterizer(const scene::Scene& scene, const RasterOptions& options, const bake::StopCheck& stop)
      : scene_(scene),
        w_(options.width),
        h_(options.height),
        k_(options.samples_per_axis),
        window_(whole_or(options.window, options.width, options.height)),
        stop_(stop) {}

  static RasterOptions::Window whole_or(const RasterOptions::Window& w, int width, int height) {
    if (w.width > 0 && w.height > 0) return w;
    return {0, 0, width, height};
  }

  void triangle(const InstanceJob& job, uint32_t t, BlockResult& out) const {
    RasterReport& report = out.report;
    if (job.mask && t < job.mask->size() && !(*job.mask)[t]) {
      ++report.masked;
      return;
    }
    std::array<uint32_t, 3> idx;
    std::array<Point2, 3> uv;  // texel space
    WorldTriangle world;
    world.ref = {job.instance, job.mesh, t};
    if (!vertices(job, world, idx, uv, report)) return;
    const double d = cross2(sub(uv[1], uv[0]), sub(uv[2], uv[0]));  // twice the signed texel-space area
    if (!(0.5 * std::fabs(d) > kMinCoverage)) return note_skip(report, world.ref, SkipReason::degenerate_uv);
    if (!frame(job, d, world)) return note_skip(report, world.ref, SkipReason::degenerate_world);
    normals(job, idx, world);
    if (!world.normals_ok) ++report.unusable_normals;
    for (const Point2& q : uv) {
      if (q.x < 0 || q.x > w_ || q.y < 0 || q.y > h_) {
        ++report.outside_unit_square;
        break;
      }
    }
    TexelRange r = texel_range(uv, w_, h_);
    r.x0 = std::max(r.x0, window_.x0);
    r.y0 = std::max(r.y0, window_.y0);
    r.x1 = std::min(r.x1, window_.x0 + window_.width - 1);
    r.y1 = std::min(r.y1, window_.y0 + window_.height - 1);
    const auto world_index = static_cast<uint32_t>(out.triangles.size());
    bool covered_any = false;
    for (int y = r.y0; y <= r.y1; ++y) {
      // A triangle may cover the whole map: polled every 16 rows (at most 16 · 16384 texels, milliseconds).
      if ((y - r.y0) % 16 == 15) stop_.check();
      for (int x = r.x0; x <= r.x1; ++x) covered_any |= texel(x, y, uv, d, world_index, out.fragments);
    }
    if (covered_any) {
      ++report.rasterized;
      out.triangles.push_back(world);
    }
  }

 private:
  // The vertex indices, texel-space UVs and world positions; false (and noted) when an index is out of range or a
  // value is not finite.
  bool vertices(const InstanceJob& job, WorldTriangle& world, std::array<uint32_t, 3>& idx, std::array<Point2, 3>& uv,
                RasterReport& report) const {
    const scene::Mesh& mesh = scene_.meshes[job.mesh];
    const scene::Transform& to_world = scene_.instances[job.instance].to_world;
    const uint32_t t = world.ref.triangle;
    for (int i = 0; i < 3; ++i) {
      idx[i] = mesh.indices[3 * static_cast<size_t>(t) + i];
      if (idx[i] >= mesh.positions.size()) {
        note_skip(report, world.ref, SkipReason::index_out_of_range);
        return false;
      }
    }
    for (int i = 0; i < 3; ++i) {
      const Point2 l = mesh.lightmap_uv[idx[i]];
      const auto& so = job.scale_offset;
      uv[i] = {(so[0] * l.x + so[2]) * w_, (so[1] * l.y + so[3]) * h_};
      world.p[i] = to_world.point(mesh.positions[idx[i]]);
      if (!finite(uv[i]) || !is_finite(world.p[i])) {
        note_skip(report, world.ref, SkipReason::non_finite_vertex);
        return false;
      }
    }
    return true;
  }

  // The front normal, the texel size and the ray offset from the world positions and `d`, twice the signed
  // texel-space area; false when the triangle has no area in world space.
  static bool frame(const InstanceJob& job, double d, WorldTriangle& world) {
    const std::array<Vec3, 3>& p = world.p;
    // Front-side world normal; a zero (or underflowing) cross product has no direction.
    const Vec3 cross_w = cross(p[1] - p[0], p[2] - p[0]) * (job.normal_transform.det < 0 ? -1.0 : 1.0);
    const double twice_world_area = length(cross_w);
    if (!(twice_world_area > 0) || !std::isfinite(twice_world_area)) return false;
    world.ng = cross_w / twice_world_area;
    if (!is_finite(world.ng)) return false;
    // Both areas are positive and finite here; the ratio can still overflow a float for absurd UV layouts.
    const double texel_size = std::sqrt(twice_world_area / std::fabs(d));
    world.texel_size = static_cast<float>(std::min(texel_size, static_cast<double>(std::numeric_limits<float>::max())));
    // The tracer's bound for this triangle as it holds it (world vertices rounded to float once). Any point of the
    // triangle has coordinates no larger than its vertices', so one value serves all its samples.
    const auto to_float = [](const Vec3& v) {
      return Vec3{static_cast<float>(v.x), static_cast<float>(v.y), static_cast<float>(v.z)};
    };
    world.ray_offset = static_cast<float>(
        scene::self_intersection_offset(to_float(p[0]), to_float(p[1]), to_float(p[2]), to_float(p[0])));
    return true;
  }

  // The unit world vertex normals, or normals_ok = false when the mesh has none or one is unusable.
  void normals(const InstanceJob& job, const std::array<uint32_t, 3>& idx, WorldTriangle& world) const {
    const scene::Mesh& mesh = scene_.meshes[job.mesh];
    world.normals_ok = job.normals_usable;
    for (int i = 0; i < 3 && world.normals_ok; ++i) {
      const Vec3 n = job.normal_transform.apply(mesh.normals[idx[i]]);
      const double len = length(n);
      world.normals_ok = len > 0 && std::isfinite(len) && is_finite(n / len);
      if (world.normals_ok) world.n[i] = n / len;
    }
  }

  // The fragments of texel (x, y) for the triangle with texel-space vertices uv and twice-signed-area d; false when
  // the triangle does not cover the texel.
  bool texel(int x, int y, const std::array<Point2, 3>& uv, double d, uint32_t world_index,
             std::vector<Fragment>& out) const {
    // Relative to the texel's corner: small coordinates keep the clip and the barycentrics accurate.
    const Point2 corner{static_cast<double>(x), static_cast<double>(y)};
    const Point2 a = sub(uv[0], corner), b = sub(uv[1], corner), c = sub(uv[2], corner);
    const double orientation = d > 0 ? 1.0 : -1.0;  // UV charts may be mirrored: either winding is fine
    const Coverage coverage = corner_coverage(a, b, c, orientation);
    if (coverage == Coverage::none) return false;
    Polygon clipped;
    double covered = 1.0;
    if (coverage == Coverage::partial) {
      clipped = clip_to_unit_square(a, b, c);
      covered = area(clipped);
      if (!(covered > kMinCoverage)) return false;
    }
    const uint32_t texel =
        static_cast<uint32_t>(static_cast<size_t>(y - window_.y0) * window_.width + (x - window_.x0));
    const auto emit = [&](const std::array<double, 3>& b_raw, double weight) {
      const std::array<double, 3> bary = clamp_barycentric(b_raw);
      out.push_back({texel, world_index, bary[1], bary[2], weight});
    };
    // The pattern points inside the triangle share its coverage equally.
    std::array<std::array<double, 3>, 16 * 16> inside;
    const int n_inside = pattern_points(a, b, c, d, inside);
    for (int m = 0; m < n_inside; ++m) emit(inside[m], covered / n_inside);
    if (n_inside == 0) {
      // A sliver between the pattern points: the mean of the clipped polygon's vertices is in the covered region (a
      // convex combination of its vertices). (A whole texel always holds the pattern's points, so the clip was made;
      // it is made here should rounding ever say otherwise.)
      if (coverage == Coverage::whole) clipped = clip_to_unit_square(a, b, c);
      emit(barycentric(vertex_mean(clipped), a, b, c, d), covered);
    }
    return true;
  }

  // The barycentrics of the points of the texel's k×k pattern that lie in the triangle; their count.
  int pattern_points(Point2 a, Point2 b, Point2 c, double d, std::array<std::array<double, 3>, 16 * 16>& inside) const {
    const double inv_k = 1.0 / k_;
    int n_inside = 0;
    for (int j = 0; j < k_; ++j) {
      for (int i = 0; i < k_; ++i) {
        const Point2 q{(i + 0.5) * inv_k, (j + 0.5) * inv_k};
        const auto bary = barycentric(q, a, b, c, d);
        if (bary[0] >= 0 && bary[1] >= 0 && bary[2] >= 0) inside[n_inside++] = bary;
      }
    }
    return n_inside;
  }

  const scene::Scene& scene_;
  int w_, h_, k_;
  RasterOptions::Window window_;  // the texels made, in the map's texel coordinates
  const bake::StopCheck& stop_;
};

void merge(RasterReport& into, const RasterReport& from) {
  into.rasterized += from.rasterized;
  into.masked += from.masked;
  for (int r = 0; r < kSkipReasonCount; ++r) into.skipped[r] += from.skipped[r];
  for (const auto& e : from.skipped_examples) {
    if (into.skipped_examples.size() < RasterReport::kMaxSkippedExamples) into.skipped_examples.push_back(e);
  }
  into.outside_unit_square += from.outside_unit_square;
  into.unusable_normals += from.unusable_normals;
}

void check_options(const RasterOptions& o) {
  const auto range = [](const char* field, int v, int lo, int hi) {
    if (v < lo || v > hi) {
      throw std::invalid_argument(std::string("lightmap rasterization: ") + field + " must be in [" +
                                  std::to_string(lo) + ", " + std::to_string(hi) + "], got " + std::to_string(v));
    }
  };
  range("width", o.width, 1, 16384);
  range("height", o.height, 1, 16384);
  range("samples_per_axis", o.samples_per_axis, 1, 16);
  const RasterOptions::Window& w = o.window;
  if (w.width > 0 || w.height > 0) {
    range("window.x0", w.x0, 0, o.width - 1);
    range("window.y0", w.y0, 0, o.height - 1);
    range("window.width", w.width, 1, o.width - w.x0);
    range("window.height", w.height, 1, o.height - w.y0);
  }
}

// The instances of lightmap `name`, and their triangles as one global sequence of `total`; instances that cannot
// bake at all are noted in the report.
std::vector<InstanceJob> instance_jobs(const scene::Scene& scene, const std::string& name, const RasterOptions& options,
                                       RasterReport& report, size_t& total) {
  std::vector<InstanceJob> jobs;
  total = 0;
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    const scene::Instance& inst = scene.instances[i];
    if (!inst.bake || scene::resolved_lightmap_name(scene, inst) != name) continue;
    ++report.instances;
    const TriangleRef whole{static_cast<uint32_t>(i), static_cast<uint32_t>(std::max(inst.mesh, 0)), 0};
    if (inst.mesh < 0 || static_cast<size_t>(inst.mesh) >= scene.meshes.size()) {
      note_skip(report, whole, SkipReason::no_mesh);
      continue;
    }
    const scene::Mesh& mesh = scene.meshes[inst.mesh];
    const size_t triangles = mesh.indices.size() / 3;
    report.triangles += triangles;
    if (mesh.lightmap_uv.empty() || mesh.lightmap_uv.size() != mesh.positions.size()) {
      // Counted per triangle, reported once for the instance.
      report.skipped[static_cast<int>(SkipReason::no_lightmap_uv)] += triangles;
      if (report.skipped_examples.size() < RasterReport::kMaxSkippedExamples) {
        report.skipped_examples.push_back({whole, SkipReason::no_lightmap_uv});
      }
      continue;
    }
    if (mesh.indices.size() % 3 != 0) {
      // The trailing indices form no triangle; the whole ones still bake.
      note_skip(report, {whole.instance, whole.mesh, static_cast<uint32_t>(triangles)}, SkipReason::index_out_of_range);
    }
    InstanceJob job;
    job.instance = static_cast<uint32_t>(i);
    job.mesh = static_cast<uint32_t>(inst.mesh);
    job.first_triangle = total;
    job.triangles = triangles;
    job.normal_transform = NormalTransform(inst.to_world);
    job.normals_usable = mesh.normals.size() == mesh.positions.size();
    job.scale_offset = inst.lightmap_scale_offset;
    if (options.bake_mask && static_cast<size_t>(inst.mesh) < options.bake_mask->size()) {
      job.mask = &(*options.bake_mask)[inst.mesh];
    }
    jobs.push_back(job);
    total += triangles;
  }
  return jobs;
}

// Rasterizes the global triangle sequence in fixed blocks, in parallel: concatenated in order, the blocks' results
// do not depend on the thread count.
std::vector<BlockResult> rasterize_blocks(const Rasterizer& rasterizer, const std::vector<InstanceJob>& jobs,
                                          size_t total, const std::vector<uint32_t>* subset,
                                          const bake::StopCheck& stop) {
  constexpr size_t kBlock = 2048;
  if (subset) total = subset->size();
  const size_t blocks = (total + kBlock - 1) / kBlock;
  std::vector<BlockResult> results(blocks);
  tbb::parallel_for(size_t{0}, blocks, [&](size_t block) {
    stop.check();  // thrown out of parallel_for, which cancels the other blocks
    const size_t begin = block * kBlock, end = std::min(total, begin + kBlock);
    BlockResult& result = results[block];
    // Reserved at once for every triangle of the block: growing, the vector would hold up to three times that.
    result.triangles.reserve(end - begin);
    const auto global = [&](size_t i) -> size_t { return subset ? (*subset)[i] : i; };
    // The instance holding the block's first triangle, then walk forward (the subset is ascending).
    size_t j = static_cast<size_t>(std::upper_bound(jobs.begin(), jobs.end(), global(begin),
                                                    [](size_t g, const InstanceJob& job) {
                                                      return g < job.first_triangle;
                                                    }) -
                                   jobs.begin() - 1);
    for (size_t i = begin; i < end; ++i) {
      const size_t g = global(i);
      while (g >= jobs[j].first_triangle + jobs[j].triangles) ++j;
      rasterizer.triangle(jobs[j], static_cast<uint32_t>(g - jobs[j].first_triangle), result);
    }
  });
  return results;
}

// Counting sort of the blocks' fragments by texel, stable (scene order within a texel), with out.first set: each
// fragment's `texel` becomes its index among the samples, so that the samples can be made in place, block by block.
// Merges the blocks' reports. Returns the number of fragments.
size_t sort_fragments(std::vector<BlockResult>& results, const std::string& name, LightmapTexels& out,
                      const bake::StopCheck& stop) {
  // One block may hold every fragment of a map (a few big triangles): polled every 2^16 fragments.
  constexpr size_t kPoll = size_t{1} << 16;
  const size_t texels = out.texel_count();
  std::vector<uint32_t>& count = out.first;  // counts, then offsets (fewer than 2^32: checked below)
  count.assign(texels + 1, 0);
  uint64_t fragments = 0;
  for (BlockResult& r : results) {
    merge(out.report, r.report);
    for (size_t j = 0; j < r.fragments.size(); ++j) {
      if (j % kPoll == 0) stop.check();
      ++count[r.fragments[j].texel + 1];
    }
    fragments += r.fragments.size();
  }
  if (fragments > std::numeric_limits<uint32_t>::max()) {
    throw std::invalid_argument("lightmap '" + name + "': " + std::to_string(fragments) +
                                " sample points exceed the limit of 2^32 - 1; lower the resolution or "
                                "samples_per_axis");
  }
  for (size_t i = 0; i < texels; ++i) count[i + 1] += count[i];
  std::vector<uint32_t> cursor(count.begin(), count.end() - 1);
  for (BlockResult& r : results) {
    for (size_t j = 0; j < r.fragments.size(); ++j) {
      if (j % kPoll == 0) stop.check();
      Fragment& f = r.fragments[j];
      f.texel = cursor[f.texel]++;
    }
  }
  return static_cast<size_t>(fragments);
}

// Texels whose weights sum above 1: overlapping charts. 1e-9 is far above the rounding of summing the clipped areas
// of the few triangles sharing a texel (~10⁻¹⁵) and far below any real overlap worth reporting.
size_t overlapping_texels(const LightmapTexels& texels) {
  size_t n = 0;
  for (size_t t = 0; t < texels.texel_count(); ++t) {
    double sum = 0;
    for (const TexelSample& s : texels.at(t)) sum += s.weight;
    if (sum > 1.0 + 1e-9) ++n;
  }
  return n;
}

}  // namespace

const char* to_string(SkipReason reason) {
  switch (reason) {
    case SkipReason::no_mesh:
      return "the instance's mesh index does not exist";
    case SkipReason::no_lightmap_uv:
      return "the mesh has no lightmap UVs (or not one per vertex)";
    case SkipReason::index_out_of_range:
      return "a vertex index is out of range";
    case SkipReason::non_finite_vertex:
      return "a position or lightmap UV is NaN or infinite";
    case SkipReason::degenerate_uv:
      return "zero area in lightmap UV space";
    case SkipReason::degenerate_world:
      return "zero area in world space";
  }
  return "unknown";
}

size_t RasterReport::skipped_total() const {
  size_t n = 0;
  for (size_t s : skipped) n += s;
  return n;
}

std::vector<uint8_t> LightmapTexels::validity() const {
  std::vector<uint8_t> v(texel_count());
  for (size_t i = 0; i < v.size(); ++i) v[i] = valid(i) ? 1 : 0;
  return v;
}

size_t LightmapTexels::valid_count() const {
  size_t n = 0;
  for (size_t i = 0; i < texel_count(); ++i) n += valid(i) ? 1 : 0;
  return n;
}

void LightmapTexels::retain(const std::vector<uint8_t>& keep) {
  if (keep.size() != samples.size()) {
    throw std::invalid_argument("LightmapTexels::retain: keep has " + std::to_string(keep.size()) + " entries for " +
                                std::to_string(samples.size()) + " samples");
  }
  // In place: the kept samples move down, never past one not yet read; first[texel] is rewritten after its texel's
  // old range [first[texel], first[texel + 1]) has been read.
  uint32_t kept = 0;
  for (size_t texel = 0; texel < texel_count(); ++texel) {
    const uint32_t begin = first[texel], end = first[texel + 1];
    first[texel] = kept;
    for (uint32_t j = begin; j < end; ++j) {
      if (keep[j]) samples[kept++] = samples[j];
    }
  }
  first[texel_count()] = kept;
  samples.resize(kept);
}

std::vector<std::string> lightmap_names(const scene::Scene& scene) {
  std::vector<std::string> names;
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    if (!scene.instances[i].bake) continue;
    const std::string name = scene::resolved_lightmap_name(scene, scene.instances[i]);
    if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
  }
  return names;
}

RasterOptions::Window TileBins::window(size_t tile) const {
  const int tx = static_cast<int>(tile % static_cast<size_t>(tiles_x)), ty = static_cast<int>(tile / tiles_x);
  const int x0 = tx * tile_size, y0 = ty * tile_size;
  return {x0, y0, std::min(tile_size, width - x0), std::min(tile_size, height - y0)};
}

TileBins bin_triangles(const scene::Scene& scene, const std::string& name, const RasterOptions& options, int tile_size,
                       const bake::StopCheck& stop) {
  RasterOptions whole = options;
  whole.window = {};
  check_options(whole);
  if (tile_size < 1 || tile_size > 16384) {
    throw std::invalid_argument("lightmap tiles: tile_size must be in [1, 16384], got " + std::to_string(tile_size));
  }
  TileBins bins;
  bins.width = options.width;
  bins.height = options.height;
  bins.tile_size = tile_size;
  bins.tiles_x = (options.width + tile_size - 1) / tile_size;
  bins.tiles_y = (options.height + tile_size - 1) / tile_size;
  const size_t tiles = static_cast<size_t>(bins.tiles_x) * bins.tiles_y;
  bins.triangles.resize(tiles);
  bins.coverage.assign(tiles, 0.0);
  RasterReport ignored;
  size_t total = 0;
  const std::vector<InstanceJob> jobs = instance_jobs(scene, name, options, ignored, total);
  if (total > std::numeric_limits<uint32_t>::max()) {
    throw std::invalid_argument("lightmap '" + name + "': " + std::to_string(total) +
                                " triangles exceed the 2^32 - 1 a tiled page can bin");
  }
  const double w = options.width, h = options.height;
  for (const InstanceJob& job : jobs) {
    const scene::Mesh& mesh = scene.meshes[job.mesh];
    for (size_t t = 0; t < job.triangles; ++t) {
      if (t % 4096 == 4095) stop.check();
      const auto g = static_cast<uint32_t>(job.first_triangle + t);
      if (job.mask && t < job.mask->size() && !(*job.mask)[t]) continue;
      std::array<Point2, 3> uv;
      bool usable = true;
      for (int i = 0; i < 3 && usable; ++i) {
        const uint32_t index = mesh.indices[3 * t + i];
        usable = index < mesh.lightmap_uv.size();
        if (!usable) break;
        const Point2 l = mesh.lightmap_uv[index];
        const auto& so = job.scale_offset;
        uv[i] = {(so[0] * l.x + so[2]) * w, (so[1] * l.y + so[3]) * h};
        usable = finite(uv[i]);
      }
      const TexelRange r = usable ? texel_range(uv, options.width, options.height) : TexelRange{0, 0, -1, -1};
      if (r.x0 > r.x1 || r.y0 > r.y1) {
        // Unusable, or outside the map: rasterizing it in one tile reports it once.
        bins.triangles[0].push_back(g);
        continue;
      }
      for (int ty = r.y0 / tile_size; ty <= r.y1 / tile_size; ++ty) {
        for (int tx = r.x0 / tile_size; tx <= r.x1 / tile_size; ++tx) {
          const size_t tile = static_cast<size_t>(ty) * bins.tiles_x + tx;
          bins.triangles[tile].push_back(g);
          // The triangle clipped to the tile's square, in texels.
          Polygon p, q;
          p.v[0] = uv[0], p.v[1] = uv[1], p.v[2] = uv[2], p.n = 3;
          const double x0 = tx * tile_size, y0 = ty * tile_size;
          clip_half_plane<0>(p, q, x0, +1.0), std::swap(p, q);
          if (p.n > 0) clip_half_plane<0>(p, q, std::min(w, x0 + tile_size), -1.0), std::swap(p, q);
          if (p.n > 0) clip_half_plane<1>(p, q, y0, +1.0), std::swap(p, q);
          if (p.n > 0) clip_half_plane<1>(p, q, std::min(h, y0 + tile_size), -1.0), std::swap(p, q);
          if (p.n > 0) bins.coverage[tile] += area(p);
        }
      }
    }
  }
  return bins;
}

size_t raster_bytes_per_fragment() { return sizeof(Fragment); }
size_t raster_bytes_per_triangle() { return sizeof(WorldTriangle); }

LightmapTexels rasterize_lightmap(const scene::Scene& scene, const std::string& name, const RasterOptions& options,
                                  const bake::StopCheck& stop) {
  LightmapTexels out;
  rasterize_lightmap_into(out, scene, name, options, stop);
  return out;
}

void rasterize_lightmap_into(LightmapTexels& out, const scene::Scene& scene, const std::string& name,
                             const RasterOptions& options, const bake::StopCheck& stop) {
  check_options(options);
  out.report = RasterReport{};
  const RasterOptions::Window window = Rasterizer::whole_or(options.window, options.width, options.height);
  out.width = window.width;
  out.height = window.height;
  size_t total = 0;
  const std::vector<InstanceJob> jobs = instance_jobs(scene, name, options, out.report, total);
  if (options.triangles && !options.triangles->empty() && options.triangles->back() >= total) {
    throw std::invalid_argument("lightmap '" + name + "': triangle " + std::to_string(options.triangles->back()) +
                                " of a tile's bin is beyond the map's " + std::to_string(total) + " triangles");
  }
  std::vector<BlockResult> results =
      rasterize_blocks(Rasterizer(scene, options, stop), jobs, total, options.triangles, stop);
  stop.check();
  const size_t fragments = sort_fragments(results, name, out, stop);
  stop.check();
  // The samples, each written once at its sorted place, in parallel over the blocks. Reused storage keeps its
  // capacity: a tiled bake rasterizes every tile into the last one's.
  out.samples.clear();
  bake::resize_polled(out.samples, fragments, stop);
  tbb::parallel_for(size_t{0}, results.size(), [&](size_t block) {
    const std::vector<Fragment>& block_fragments = results[block].fragments;
    const std::vector<WorldTriangle>& world = results[block].triangles;
    for (size_t j = 0; j < block_fragments.size(); ++j) {
      if (j % 4096 == 0) stop.check();
      const Fragment& f = block_fragments[j];
      out.samples[f.texel] = world[f.world].sample({1.0 - f.b1 - f.b2, f.b1, f.b2}, f.weight);
    }
  });
  stop.check();
  out.report.overlapping_texels = overlapping_texels(out);
}

}  // namespace kiln::lightmap
