#include "bakers/scene/scene_check.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <sstream>
#include <utility>

#include "bakers/scene/lightmap_file_names.h"

namespace kiln::scene {
namespace {

// A triangle is "flat at float precision" when its area is below 2^-20 of the square of its longest edge, i.e. its
// smallest angle is below ~1e-6 rad. Embree computes the normal of a triangle in float: the cross product of the edges
// carries an absolute error of ~3·2^-24·ℓ², so at |e1 × e2| ≤ 2^-20·ℓ² the normal's direction is off by ~0.2 rad or
// more, and the ray offset that keeps spawned rays off such a triangle (ray_offset.h) grows past its own width. The
// same ratio is used for lightmap UVs: mapping a UV point back to barycentrics divides by the UV area, amplifying the
// UV's rounding error by ℓ²/(2A), which at 2^20 leaves the barycentrics ~1e-10 accurate in double but the triangle
// covers essentially no texel area.
constexpr double kFlatRatio = 0x1.0p-20;

bool finite2(const Point2& p) { return std::isfinite(p.x) && std::isfinite(p.y); }

double cross2(const Point2& a, const Point2& b, const Point2& c) {
  return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

double length2(const Point2& a, const Point2& b) { return std::hypot(b.x - a.x, b.y - a.y); }

std::string fmt(double v) {
  std::ostringstream s;
  s.precision(9);
  s << v;
  return s.str();
}
std::string fmt(const Vec3& v) { return "(" + fmt(v.x) + ", " + fmt(v.y) + ", " + fmt(v.z) + ")"; }
std::string fmt(const Point2& v) { return "(" + fmt(v.x) + ", " + fmt(v.y) + ")"; }

std::string mesh_label(const Scene& scene, int m) {
  const std::string& n = scene.meshes[m].name;
  return "mesh " + std::to_string(m) + (n.empty() ? std::string() : " '" + n + "'");
}

class Reporter {
 public:
  Reporter(SceneReport& report, size_t max_listed) : report_(report), max_listed_(max_listed) {}
  void add(Problem p) {
    const int k = static_cast<int>(p.kind);
    if (static_cast<size_t>(report_.counts[k]) < max_listed_) report_.problems.push_back(std::move(p));
    ++report_.counts[k];
  }

 private:
  SceneReport& report_;
  size_t max_listed_;
};

Problem problem(Severity s, ProblemKind k, int mesh, int instance, int64_t triangle, std::string what,
                std::string action) {
  Problem p;
  p.severity = s;
  p.kind = k;
  p.mesh = mesh;
  p.instance = instance;
  p.triangle = triangle;
  p.what = std::move(what);
  p.action = std::move(action);
  return p;
}

// ---------------------------------------------------------------------------------------------------------------
// Overlap of lightmap UV triangles within one lightmap.

struct UvTriangle {
  Point2 p[3];
  double min_x, min_y, max_x, max_y;
  int mesh, instance;  // input indices, for the report
  uint32_t triangle;   // input triangle index
};

// Overlaps thinner than this (in UV units) are ignored: charts packed edge to edge meet with rounding-level overlaps
// of ~1e-16, and 2^-20 ≈ 1e-6 is far below a texel at any resolution the baker allows (≤ 16384 texels: 6e-5).
constexpr double kOverlapTolerance = 0x1.0p-20;

// Separating-axis test of two triangles in the plane: their interiors overlap with positive area unless the
// projections on one of the six edge normals are disjoint (touching counts as disjoint, up to kOverlapTolerance).
// Triangles sharing an edge are separated by that edge's normal with identical projections of the shared vertices.
bool overlap(const UvTriangle& a, const UvTriangle& b) {
  const UvTriangle* tris[2] = {&a, &b};
  for (const UvTriangle* t : tris) {
    for (int e = 0; e < 3; ++e) {
      const Point2& p0 = t->p[e];
      const Point2& p1 = t->p[(e + 1) % 3];
      const double ax = -(p1.y - p0.y), ay = p1.x - p0.x;  // edge normal (unnormalized)
      const double len = std::hypot(ax, ay);
      // A zero-length edge gives no axis; degenerate UV triangles are excluded before this test.
      if (len == 0) continue;
      double amin = INFINITY, amax = -INFINITY, bmin = INFINITY, bmax = -INFINITY;
      for (int i = 0; i < 3; ++i) {
        const double pa = ax * a.p[i].x + ay * a.p[i].y, pb = ax * b.p[i].x + ay * b.p[i].y;
        amin = std::min(amin, pa), amax = std::max(amax, pa), bmin = std::min(bmin, pb), bmax = std::max(bmax, pb);
      }
      const double tol = kOverlapTolerance * len;
      if (amax <= bmin + tol || bmax <= amin + tol) return false;
    }
  }
  return true;
}

// Uniform grid over the triangles' UV bounds with about two cells per triangle; each pair is tested once, in the
// cell holding the lower corner of the intersection of their bounding boxes. Linear in the number of triangles for
// charts of similar-sized triangles; the listed pairs are bounded by the reporter, the count is exact.
void find_overlaps(const std::string& lightmap, const std::vector<UvTriangle>& tris, Reporter& reporter) {
  if (tris.size() < 2) return;
  double x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY;
  for (const UvTriangle& t : tris) {
    x0 = std::min(x0, t.min_x), y0 = std::min(y0, t.min_y), x1 = std::max(x1, t.max_x), y1 = std::max(y1, t.max_y);
  }
  const int n = static_cast<int>(std::clamp(std::ceil(std::sqrt(2.0 * static_cast<double>(tris.size()))), 1.0, 2048.0));
  // UVs were checked to lie in [0,1]: the extent is finite; a zero extent is excluded by the UV-area check.
  const double sx = n / std::max(x1 - x0, 1e-300), sy = n / std::max(y1 - y0, 1e-300);
  auto cell_x = [&](double x) { return std::clamp(static_cast<int>((x - x0) * sx), 0, n - 1); };
  auto cell_y = [&](double y) { return std::clamp(static_cast<int>((y - y0) * sy), 0, n - 1); };
  std::vector<std::vector<uint32_t>> cells(static_cast<size_t>(n) * n);
  for (uint32_t i = 0; i < tris.size(); ++i) {
    const UvTriangle& t = tris[i];
    for (int cy = cell_y(t.min_y); cy <= cell_y(t.max_y); ++cy)
      for (int cx = cell_x(t.min_x); cx <= cell_x(t.max_x); ++cx) cells[static_cast<size_t>(cy) * n + cx].push_back(i);
  }
  for (int cy = 0; cy < n; ++cy) {
    for (int cx = 0; cx < n; ++cx) {
      const std::vector<uint32_t>& cell = cells[static_cast<size_t>(cy) * n + cx];
      for (size_t i = 0; i < cell.size(); ++i) {
        for (size_t j = i + 1; j < cell.size(); ++j) {
          const UvTriangle& a = tris[cell[i]];
          const UvTriangle& b = tris[cell[j]];
          const double ix = std::max(a.min_x, b.min_x), iy = std::max(a.min_y, b.min_y);
          if (ix > std::min(a.max_x, b.max_x) || iy > std::min(a.max_y, b.max_y)) continue;
          if (cell_x(ix) != cx || cell_y(iy) != cy) continue;  // this pair's test belongs to another cell
          if (!overlap(a, b)) continue;
          Problem p = problem(Severity::warning, ProblemKind::overlapping_lightmap_uv, a.mesh, a.instance, a.triangle,
                              "lightmap '" + lightmap + "': lightmap UVs of triangle " + std::to_string(a.triangle) +
                                  " (mesh " + std::to_string(a.mesh) + ", instance " + std::to_string(a.instance) +
                                  ") overlap those of triangle " + std::to_string(b.triangle) + " (mesh " +
                                  std::to_string(b.mesh) + ", instance " + std::to_string(b.instance) + ")",
                              "both are baked and share the texels they overlap; give them separate lightmap UV "
                              "space (or the instances separate lightmap_scale_offset rectangles)");
          p.other_triangle = b.triangle;
          p.other_mesh = b.mesh;
          p.other_instance = b.instance;
          reporter.add(std::move(p));
        }
      }
    }
  }
}

bool valid_scale_offset(const std::array<double, 4>& st) {
  for (double v : st)
    if (!std::isfinite(v)) return false;
  // The rectangle [o, o + s] must be non-empty and inside [0,1]².
  return st[0] > 0 && st[1] > 0 && st[2] >= 0 && st[3] >= 0 && st[2] + st[0] <= 1 && st[3] + st[1] <= 1;
}

}  // namespace

const char* to_string(ProblemKind kind) {
  switch (kind) {
    case ProblemKind::no_lightmap_uv:
      return "no_lightmap_uv";
    case ProblemKind::array_size_mismatch:
      return "array_size_mismatch";
    case ProblemKind::index_count:
      return "index_count";
    case ProblemKind::index_out_of_range:
      return "index_out_of_range";
    case ProblemKind::non_finite_vertex:
      return "non_finite_vertex";
    case ProblemKind::degenerate_triangle:
      return "degenerate_triangle";
    case ProblemKind::lightmap_uv_out_of_range:
      return "lightmap_uv_out_of_range";
    case ProblemKind::degenerate_lightmap_uv:
      return "degenerate_lightmap_uv";
    case ProblemKind::overlapping_lightmap_uv:
      return "overlapping_lightmap_uv";
    case ProblemKind::material_out_of_range:
      return "material_out_of_range";
    case ProblemKind::bad_normal:
      return "bad_normal";
    case ProblemKind::non_finite_uv:
      return "non_finite_uv";
    case ProblemKind::bad_transform:
      return "bad_transform";
    case ProblemKind::bad_instance_mesh:
      return "bad_instance_mesh";
    case ProblemKind::bad_lightmap_scale_offset:
      return "bad_lightmap_scale_offset";
    case ProblemKind::no_materials:
      return "no_materials";
    case ProblemKind::bad_texture:
      return "bad_texture";
    case ProblemKind::bad_material_value:
      return "bad_material_value";
    case ProblemKind::renamed_lightmap:
      return "renamed_lightmap";
  }
  return "unknown";
}

const char* to_string(Severity severity) { return severity == Severity::error ? "error" : "warning"; }

int64_t SceneReport::total() const {
  int64_t n = 0;
  for (int64_t c : counts) n += c;
  return n;
}

std::string SceneReport::summary() const {
  std::ostringstream s;
  for (int k = 0; k < kProblemKindCount; ++k) {
    if (counts[k] == 0) continue;
    int64_t listed = 0;
    for (const Problem& p : problems) listed += static_cast<int>(p.kind) == k;
    s << counts[k] << " x " << to_string(static_cast<ProblemKind>(k)) << " (" << listed << " listed)\n";
  }
  for (const Problem& p : problems) s << to_string(p.severity) << ": " << p.what << "; " << p.action << "\n";
  return s.str();
}

bool usable_transform(const Transform& t) {
  for (double v : t.m)
    if (!std::isfinite(v)) return false;
  const Vec3 c0{t.m[0], t.m[4], t.m[8]}, c1{t.m[1], t.m[5], t.m[9]}, c2{t.m[2], t.m[6], t.m[10]};
  const double det = dot(c0, cross(c1, c2));
  // Normals transform by the inverse transpose, whose relative error in double is ~1e-16 times the condition of the
  // columns, ~|c0||c1||c2| / |det|. Below a relative determinant of 1e-12 that error passes 1e-4 (visible in
  // shading) and the instance is flattened to (nearly) a plane or line: treated as singular.
  const double scale = length(c0) * length(c1) * length(c2);
  return std::isfinite(det) && std::isfinite(scale) && std::fabs(det) > 1e-12 * scale;
}

const std::string& CheckedScene::input_lightmap_name(const std::string& stem) const {
  const auto it = renamed_lightmaps.find(stem);
  return it == renamed_lightmaps.end() ? stem : it->second;
}

std::string resolved_lightmap_name(const Scene& scene, const Instance& instance) {
  if (!instance.lightmap.empty()) return instance.lightmap;
  if (instance.mesh >= 0 && static_cast<size_t>(instance.mesh) < scene.meshes.size() &&
      !scene.meshes[instance.mesh].name.empty())
    return scene.meshes[instance.mesh].name;
  return "mesh" + std::to_string(instance.mesh);
}

namespace {

// What the stages of check_scene share: the input, the cleaned scene being built and the report.
struct SceneCheck {
  const Scene& in;
  CheckedScene& out;
  Reporter report;
  std::vector<bool> has_lightmap;  // per mesh: lightmap UVs, one per position
};

// What the stages checking one mesh share.
struct MeshCheck {
  Reporter& report;
  const int m;  // the mesh's index
  const Mesh& src;
  Mesh& dst;
  CheckedScene::MeshTriangles& triangles;
  const std::string label;
  const size_t nv, nt;          // vertices, whole triangles
  const size_t material_count;  // in the cleaned scene
  bool normals_ok = false, uv_ok = false, materials_ok = false, has_lightmap = false;
  std::vector<bool> finite{};      // per vertex: its position is finite
  std::vector<Vec3> normal_sum{};  // per vertex, with normals_ok: the sum of the kept triangles' ng around it
};

// ---------------------------------------------------------------------------------------------------------------
// Materials and textures.

void add_default_material(SceneCheck& c) {
  if (!c.out.scene.materials.empty()) return;
  SceneMaterial grey;
  grey.name = "default";
  grey.base_color = Rgb(0.5);
  c.out.scene.materials.push_back(grey);
  c.report.add(problem(Severity::warning, ProblemKind::no_materials, -1, -1, -1, "the scene has no materials",
                       "every triangle uses a grey Lambert material of albedo 0.5"));
}

void drop_bad_textures(SceneCheck& c) {
  Scene& scene = c.out.scene;
  std::vector<bool> texture_ok(scene.textures.size());
  for (size_t i = 0; i < scene.textures.size(); ++i) {
    const Texture& t = scene.textures[i];
    texture_ok[i] =
        t.width > 0 && t.height > 0 && t.texels.size() == static_cast<size_t>(t.width) * static_cast<size_t>(t.height);
  }
  for (SceneMaterial& m : scene.materials) {
    if (!m.base_color_texture) continue;
    const int t = *m.base_color_texture;
    const bool in_range = t >= 0 && static_cast<size_t>(t) < scene.textures.size();
    if (in_range && texture_ok[t]) continue;
    c.report.add(problem(
        Severity::warning, ProblemKind::bad_texture, -1, -1, -1,
        "material '" + m.name + "': base colour texture " + std::to_string(t) +
            (in_range ? " has " + std::to_string(scene.textures[t].texels.size()) + " texels for " +
                            std::to_string(scene.textures[t].width) + "x" + std::to_string(scene.textures[t].height)
                      : " does not exist (" + std::to_string(scene.textures.size()) + " textures)"),
        "the texture is ignored; the material uses its base colour alone"));
    m.base_color_texture.reset();
  }
}

// Clamps each channel of `colour` to [0, hi] (NaN → 0) and reports the change, if any.
void repair_colour(Reporter& report, const SceneMaterial& m, Rgb& colour, double hi, const char* what, const char* rule,
                   bool all_or_nothing) {
  Rgb fixed = colour;
  // A colour with a non-finite channel says nothing reliable about the others (lights.h's usable_emission).
  if (all_or_nothing && !colour.is_finite()) fixed = Rgb{0.0};
  double* ch[3] = {&fixed.r, &fixed.g, &fixed.b};
  for (double* v : ch) {
    if (!std::isfinite(*v) || *v < 0) *v = 0;
    if (*v > hi) *v = hi;
  }
  if (fixed.r == colour.r && fixed.g == colour.g && fixed.b == colour.b) return;
  report.add(problem(Severity::warning, ProblemKind::bad_material_value, -1, -1, -1,
                     "material '" + m.name + "': " + what + " (" + std::to_string(colour.r) + ", " +
                         std::to_string(colour.g) + ", " + std::to_string(colour.b) + ")",
                     rule));
  colour = fixed;
}

// Colours that cannot be a reflectance or a radiance: repaired per channel, so that nothing non-finite reaches the
// transport (a NaN channel would otherwise pass "emission > 0" tests that compare the maximum).
void repair_material_colours(SceneCheck& c) {
  for (SceneMaterial& m : c.out.scene.materials) {
    repair_colour(c.report, m, m.base_color, 1.0, "base colour is not a reflectance",
                  "NaN and negative channels set to 0, channels above 1 set to 1", false);
    repair_colour(c.report, m, m.emission, std::numeric_limits<double>::max(),
                  "emission is not a finite, non-negative radiance",
                  "a NaN or infinite channel makes the material emit nothing; negative channels set to 0", true);
  }
}

// ---------------------------------------------------------------------------------------------------------------
// Meshes.

void report_size_mismatch(MeshCheck& k, const char* array, size_t got, size_t want, const std::string& action) {
  k.report.add(problem(Severity::warning, ProblemKind::array_size_mismatch, k.m, -1, -1,
                       k.label + ": " + array + " has " + std::to_string(got) + " entries for " + std::to_string(want) +
                           (std::string(array) == "material" ? " triangles" : " positions"),
                       action));
}

// The index count and the sizes of the per-vertex and per-triangle arrays: which of them the mesh keeps.
void check_array_sizes(MeshCheck& k) {
  const Mesh& src = k.src;
  if (src.indices.size() % 3 != 0)
    k.report.add(problem(Severity::error, ProblemKind::index_count, k.m, -1, -1,
                         k.label + ": " + std::to_string(src.indices.size()) + " indices, not a multiple of 3",
                         "the last " + std::to_string(src.indices.size() % 3) + " indices are ignored"));
  k.normals_ok = src.normals.size() == k.nv;
  if (!src.normals.empty() && !k.normals_ok)
    report_size_mismatch(k, "normals", src.normals.size(), k.nv, "normals ignored: the geometric normal is used");
  k.uv_ok = src.uv.size() == k.nv;
  if (!src.uv.empty() && !k.uv_ok)
    report_size_mismatch(k, "uv", src.uv.size(), k.nv, "texture UVs ignored: textures are not sampled on this mesh");
  k.has_lightmap = !src.lightmap_uv.empty() && src.lightmap_uv.size() == k.nv;
  if (src.lightmap_uv.empty())
    k.report.add(problem(Severity::warning, ProblemKind::no_lightmap_uv, k.m, -1, -1, k.label + " has no lightmap UVs",
                         "it casts shadows and bounces light but gets no lightmap"));
  else if (!k.has_lightmap)
    report_size_mismatch(k, "lightmap_uv", src.lightmap_uv.size(), k.nv,
                         "lightmap UVs ignored: it casts shadows and bounces light but gets no lightmap");
  k.materials_ok = src.material.size() == k.nt;
  if (!src.material.empty() && !k.materials_ok)
    report_size_mismatch(k, "material", src.material.size(), k.nt,
                         "per-triangle materials ignored: every triangle uses material 0");
}

// Vertices: positions stay (indices keep their meaning) but non-finite ones become 0 once nothing uses them.
void copy_vertices(MeshCheck& k) {
  k.finite.resize(k.nv);
  k.dst.positions.resize(k.nv);
  for (size_t v = 0; v < k.nv; ++v) {
    k.finite[v] = is_finite(k.src.positions[v]);
    k.dst.positions[v] = k.finite[v] ? k.src.positions[v] : Vec3{};
  }
  if (k.has_lightmap) k.dst.lightmap_uv = k.src.lightmap_uv;
  if (!k.uv_ok) return;
  k.dst.uv = k.src.uv;
  for (size_t v = 0; v < k.nv; ++v) {
    if (finite2(k.dst.uv[v])) continue;
    Problem p = problem(Severity::warning, ProblemKind::non_finite_uv, k.m, -1, -1,
                        k.label + ": texture UV of vertex " + std::to_string(v) + " is " + fmt(k.src.uv[v]),
                        "replaced by (0, 0)");
    p.vertex = static_cast<int64_t>(v);
    k.report.add(std::move(p));
    k.dst.uv[v] = {0, 0};
  }
}

// The triangle's normal (p1 − p0) × (p2 − p0), not normalised, if it can be traced; nullopt, reported, if dropped.
std::optional<Vec3> traced_normal(MeshCheck& k, size_t t, const uint32_t (&i)[3], const std::string& tri) {
  const size_t nv = k.nv;
  const auto at = static_cast<int64_t>(t);
  if (i[0] >= nv || i[1] >= nv || i[2] >= nv) {
    k.report.add(problem(Severity::error, ProblemKind::index_out_of_range, k.m, -1, at,
                         tri + ": indices (" + std::to_string(i[0]) + ", " + std::to_string(i[1]) + ", " +
                             std::to_string(i[2]) + ") for " + std::to_string(nv) + " vertices",
                         "triangle dropped"));
    return std::nullopt;
  }
  if (!k.finite[i[0]] || !k.finite[i[1]] || !k.finite[i[2]]) {
    const uint32_t bad = !k.finite[i[0]] ? i[0] : !k.finite[i[1]] ? i[1] : i[2];
    k.report.add(problem(Severity::error, ProblemKind::non_finite_vertex, k.m, -1, at,
                         tri + ": vertex " + std::to_string(bad) + " is at " + fmt(k.src.positions[bad]),
                         "triangle dropped"));
    return std::nullopt;
  }
  const Vec3 &p0 = k.src.positions[i[0]], &p1 = k.src.positions[i[1]], &p2 = k.src.positions[i[2]];
  const Vec3 ng = cross(p1 - p0, p2 - p0);
  const double longest = std::max({length(p1 - p0), length(p2 - p1), length(p0 - p2)});
  if (!(length(ng) > kFlatRatio * longest * longest)) {
    k.report.add(
        problem(Severity::error, ProblemKind::degenerate_triangle, k.m, -1, at,
                tri + " has zero area at float precision (vertices " + fmt(p0) + ", " + fmt(p1) + ", " + fmt(p2) + ")",
                "triangle dropped: it is neither traced nor baked"));
    return std::nullopt;
  }
  return ng;
}

// The kept triangle's material, material 0 (reported) if out of range.
uint32_t checked_material(MeshCheck& k, size_t t, const std::string& tri) {
  const uint32_t mat = k.src.material[t];
  if (mat < k.material_count) return mat;
  k.report.add(problem(Severity::warning, ProblemKind::material_out_of_range, k.m, -1, static_cast<int64_t>(t),
                       tri + ": material " + std::to_string(mat) + " of " + std::to_string(k.material_count),
                       "material 0 used"));
  return 0;
}

// Whether the kept triangle bakes into the lightmap: its lightmap UVs inside [0,1] and enclosing some area.
bool bakes(MeshCheck& k, size_t t, const uint32_t (&i)[3], const std::string& tri) {
  if (!k.has_lightmap) return false;
  const Point2 &a = k.src.lightmap_uv[i[0]], &b = k.src.lightmap_uv[i[1]], &c = k.src.lightmap_uv[i[2]];
  bool inside = true;
  for (const Point2* q : {&a, &b, &c})
    inside = inside && q->x >= 0 && q->x <= 1 && q->y >= 0 && q->y <= 1;  // false for NaN too
  const double luv = std::max({length2(a, b), length2(b, c), length2(c, a)});
  if (!inside) {
    k.report.add(problem(Severity::warning, ProblemKind::lightmap_uv_out_of_range, k.m, -1, static_cast<int64_t>(t),
                         tri + ": lightmap UVs " + fmt(a) + ", " + fmt(b) + ", " + fmt(c) + " leave [0,1]",
                         "not baked into the lightmap; still casts shadows and bounces light"));
    return false;
  }
  if (!(std::fabs(cross2(a, b, c)) > kFlatRatio * luv * luv)) {
    k.report.add(problem(Severity::warning, ProblemKind::degenerate_lightmap_uv, k.m, -1, static_cast<int64_t>(t),
                         tri + ": lightmap UVs " + fmt(a) + ", " + fmt(b) + ", " + fmt(c) + " enclose no area",
                         "not baked into the lightmap; still casts shadows and bounces light"));
    return false;
  }
  return true;
}

void check_triangles(MeshCheck& k) {
  k.normal_sum.resize(k.normals_ok ? k.nv : 0);
  for (size_t t = 0; t < k.nt; ++t) {
    const uint32_t i[3] = {k.src.indices[3 * t], k.src.indices[3 * t + 1], k.src.indices[3 * t + 2]};
    const std::string tri = k.label + " triangle " + std::to_string(t);
    const std::optional<Vec3> ng = traced_normal(k, t, i, tri);
    if (!ng) continue;
    // Kept: traced.
    k.dst.indices.insert(k.dst.indices.end(), i, i + 3);
    k.triangles.source_triangle.push_back(static_cast<uint32_t>(t));
    if (k.normals_ok)
      for (uint32_t v : i) k.normal_sum[v] += *ng;  // area-weighted: |ng| = 2 × area
    if (k.materials_ok) k.dst.material.push_back(checked_material(k, t, tri));
    k.triangles.bake.push_back(bakes(k, t, i, tri) ? 1 : 0);
  }
}

// Normals: a NaN, infinite or zero normal becomes the vertex's geometric normal (the area-weighted mean of the
// normals of the kept triangles around it; a vertex no kept triangle uses gets +Y, which nothing reads).
void repair_normals(MeshCheck& k) {
  if (!k.normals_ok) return;
  k.dst.normals = k.src.normals;
  for (size_t v = 0; v < k.nv; ++v) {
    const Vec3& n = k.src.normals[v];
    if (is_finite(n) && dot(n, n) > 0) continue;
    const double len = length(k.normal_sum[v]);
    k.dst.normals[v] = len > 0 && std::isfinite(len) ? k.normal_sum[v] / len : Vec3{0, 1, 0};
    Problem p = problem(Severity::warning, ProblemKind::bad_normal, k.m, -1, -1,
                        k.label + ": normal of vertex " + std::to_string(v) + " is " + fmt(n),
                        "replaced by the geometric normal " + fmt(k.dst.normals[v]));
    p.vertex = static_cast<int64_t>(v);
    k.report.add(std::move(p));
  }
}

void check_mesh(SceneCheck& c, size_t mi) {
  const Mesh& src = c.in.meshes[mi];
  MeshCheck k{c.report,
              static_cast<int>(mi),
              src,
              c.out.scene.meshes[mi],
              c.out.triangles[mi],
              mesh_label(c.in, static_cast<int>(mi)),
              src.positions.size(),
              src.indices.size() / 3,
              c.out.scene.materials.size()};
  k.dst.name = src.name;
  check_array_sizes(k);
  c.has_lightmap[mi] = k.has_lightmap;
  copy_vertices(k);
  check_triangles(k);
  repair_normals(k);
}

// ---------------------------------------------------------------------------------------------------------------
// Instances.

// False, reported, for an instance that must be skipped.
bool traceable_instance(SceneCheck& c, size_t ii) {
  const Instance& src = c.in.instances[ii];
  const int i = static_cast<int>(ii);
  const std::string label = "instance " + std::to_string(ii);
  if (src.mesh < 0 || static_cast<size_t>(src.mesh) >= c.in.meshes.size()) {
    c.report.add(
        problem(Severity::error, ProblemKind::bad_instance_mesh, -1, i, -1,
                label + " refers to mesh " + std::to_string(src.mesh) + " of " + std::to_string(c.in.meshes.size()),
                "instance skipped"));
    return false;
  }
  if (!usable_transform(src.to_world)) {
    std::string m = "(";
    for (size_t k = 0; k < 12; ++k) m += fmt(src.to_world.m[k]) + (k == 11 ? ")" : k % 4 == 3 ? "; " : ", ");
    c.report.add(problem(Severity::error, ProblemKind::bad_transform, src.mesh, i, -1,
                         label + " of " + mesh_label(c.in, src.mesh) + " has a singular or non-finite transform " + m,
                         "instance skipped"));
    return false;
  }
  return true;
}

// Each lightmap's name becomes its file stem; a change is reported once per lightmap, at its first instance.
void name_lightmap_files(SceneCheck& c, LightmapFileNames& files, Instance& dst, size_t ii) {
  const std::string name = dst.lightmap;
  dst.lightmap = files.stem(name);
  if (dst.lightmap == name || !c.out.renamed_lightmaps.emplace(dst.lightmap, name).second) return;
  const bool unsafe = safe_file_stem(name) != name;
  c.report.add(problem(Severity::warning, ProblemKind::renamed_lightmap, dst.mesh, static_cast<int>(ii), -1,
                       "lightmap \"" + name + "\" (first named by instance " + std::to_string(ii) + ") " +
                           (unsafe ? "is not a safe file name" : "has the file name of another lightmap"),
                       "its files are named " + dst.lightmap + "_irradiance.exr and so on"));
}

void check_instances(SceneCheck& c) {
  LightmapFileNames files;
  for (size_t ii = 0; ii < c.in.instances.size(); ++ii) {
    if (!traceable_instance(c, ii)) continue;
    const Instance& src = c.in.instances[ii];
    Instance dst = src;
    dst.lightmap = resolved_lightmap_name(c.in, src);
    name_lightmap_files(c, files, dst, ii);
    if (dst.bake && !c.has_lightmap[src.mesh]) dst.bake = false;  // reported with the mesh
    if (dst.bake && !valid_scale_offset(src.lightmap_scale_offset)) {
      const auto& st = src.lightmap_scale_offset;
      c.report.add(problem(Severity::warning, ProblemKind::bad_lightmap_scale_offset, src.mesh, static_cast<int>(ii),
                           -1,
                           "instance " + std::to_string(ii) + ": lightmap_scale_offset (" + fmt(st[0]) + ", " +
                               fmt(st[1]) + ", " + fmt(st[2]) + ", " + fmt(st[3]) + ") is not a rectangle inside [0,1]",
                           "the instance casts shadows and bounces light but is not baked"));
      dst.bake = false;
    }
    c.out.scene.instances.push_back(std::move(dst));
    c.out.source_instance.push_back(static_cast<uint32_t>(ii));
  }
}

// ---------------------------------------------------------------------------------------------------------------
// Overlapping lightmap UVs.

// Every baked triangle of every baking instance of lightmap `name`, in the lightmap's UV space.
std::vector<UvTriangle> lightmap_triangles(const CheckedScene& out, const std::string& name) {
  std::vector<UvTriangle> tris;
  for (size_t k = 0; k < out.scene.instances.size(); ++k) {
    const Instance& inst = out.scene.instances[k];
    if (!inst.bake || inst.lightmap != name) continue;
    const Mesh& mesh = out.scene.meshes[inst.mesh];
    const CheckedScene::MeshTriangles& info = out.triangles[inst.mesh];
    const auto& st = inst.lightmap_scale_offset;
    for (size_t t = 0; t < info.bake.size(); ++t) {
      if (!info.bake[t]) continue;
      UvTriangle u;
      for (int c = 0; c < 3; ++c) {
        const Point2& q = mesh.lightmap_uv[mesh.indices[3 * t + c]];
        u.p[c] = {st[0] * q.x + st[2], st[1] * q.y + st[3]};
      }
      u.min_x = std::min({u.p[0].x, u.p[1].x, u.p[2].x}), u.max_x = std::max({u.p[0].x, u.p[1].x, u.p[2].x});
      u.min_y = std::min({u.p[0].y, u.p[1].y, u.p[2].y}), u.max_y = std::max({u.p[0].y, u.p[1].y, u.p[2].y});
      u.mesh = inst.mesh;
      u.instance = static_cast<int>(out.source_instance[k]);
      u.triangle = info.source_triangle[t];
      tris.push_back(u);
    }
  }
  return tris;
}

// Per lightmap, in the order the instances name them.
void find_all_overlaps(const CheckedScene& out, Reporter& reporter) {
  std::vector<std::string> names;
  for (const Instance& inst : out.scene.instances) {
    if (inst.bake && std::find(names.begin(), names.end(), inst.lightmap) == names.end())
      names.push_back(inst.lightmap);
  }
  for (const std::string& name : names) find_overlaps(name, lightmap_triangles(out, name), reporter);
}

}  // namespace

CheckedScene check_scene(const Scene& in, const CheckOptions& options) {
  CheckedScene out;
  SceneCheck c{in, out, Reporter(out.report, options.max_listed_per_kind), std::vector<bool>(in.meshes.size())};
  out.scene.materials = in.materials;
  out.scene.textures = in.textures;
  out.scene.lights = in.lights;
  out.scene.environment = in.environment;
  add_default_material(c);
  drop_bad_textures(c);
  repair_material_colours(c);
  out.scene.meshes.resize(in.meshes.size());
  out.triangles.resize(in.meshes.size());
  for (size_t m = 0; m < in.meshes.size(); ++m) check_mesh(c, m);
  check_instances(c);
  if (options.overlaps) find_all_overlaps(out, c.report);
  return out;
}

void check_overlaps(CheckedScene& checked, const CheckOptions& options) {
  Reporter reporter(checked.report, options.max_listed_per_kind);
  find_all_overlaps(checked, reporter);
}

}  // namespace kiln::scene
