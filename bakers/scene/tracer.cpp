#include "bakers/scene/tracer.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include "bakers/scene/scene_check.h"

namespace kiln::scene {
namespace {

const char* error_name(RTCError code) {
  switch (code) {
    case RTC_ERROR_NONE:
      return "no error";
    case RTC_ERROR_UNKNOWN:
      return "unknown error";
    case RTC_ERROR_INVALID_ARGUMENT:
      return "invalid argument";
    case RTC_ERROR_INVALID_OPERATION:
      return "invalid operation";
    case RTC_ERROR_OUT_OF_MEMORY:
      return "out of memory";
    case RTC_ERROR_UNSUPPORTED_CPU:
      return "unsupported CPU";
    case RTC_ERROR_CANCELLED:
      return "cancelled";
  }
  return "unrecognised error";
}

// The attributes a hit interpolates beyond position and normal, copied from the scene's mesh (shared by its
// instances).
struct MeshAttributes {
  std::vector<Point2> uv, lightmap_uv;
};

// What a hit on one triangle needs, computed once when the tracer is built, so that completing a hit is a dependent
// load after Embree returns instead of a chain through the geometry's index, vertex and normal buffers (and a
// recomputation per hit). Split by how often a hit reads it, so that the part every hit reads is one cache line: on a
// scene whose records outgrow the caches, the load after Embree returns is the tracer's largest cost.
//
// Every closest hit: the place, the normal and the offset.
struct alignas(64) TriangleRecord {
  float p[3][3];  // the world (float) vertices Embree traces, in the triangle's index order
  // self_intersection_offset of the float vertices, rounded up to a float: it depends on the triangle alone (a hit
  // point inside it is no farther from the origin than its farthest vertex, coordinate-wise).
  float offset;
  // The unit geometric normal (mirror applied), the double cross product of the float vertices normalised (kept in
  // double: front-face and horizon decisions at grazing angles rest on it); zero for a triangle whose normal
  // underflows (Embree cannot hit it, see complete()).
  double ng[3];
};
static_assert(sizeof(TriangleRecord) == 64, "one cache line per triangle");

// Every closest hit too, but small enough to stay cached (8 bytes a triangle).
struct TriangleFacts {
  int32_t material;  // into Scene::materials
  // The shading normal to interpolate: false without vertex normals, and for a triangle whose three vertex normals
  // all lie within kFlatNormal of its geometric normal (a flat face, as most lightmapped geometry is), which is
  // shaded with ng instead: interpolating could only return ng again to within the vertex normals' own float
  // rounding.
  bool interpolate_normals;
  // ng is zero (its double cross product underflowed). A flag rather than testing ng's components per hit: on
  // axis-aligned walls some component is zero on every other hit, and a short-circuit test of them mispredicts.
  bool zero_normal;
};
static_assert(sizeof(TriangleFacts) == 8);

// Only for hits that interpolate vertex normals or UVs.
struct TriangleVertices {
  float n[3][3];      // the mesh's vertex normals in world space (the inverse transpose applied, not renormalised:
                      // interpolating them and then normalising is the same as transforming the interpolated normal);
                      // unused without vertex normals
  uint32_t index[3];  // the vertex indices, for the UV attributes
};

// How far (in radians, for small angles: the length of the difference of unit vectors) a vertex normal may stand
// from its triangle's geometric normal for the triangle to count as flat. A float vertex normal is known to a
// relative 2^-24 per component, and the geometric normal of float vertices is itself off the modeller's by about
// as much again on a well-shaped triangle: 8·2^-24 ≈ 4.8e-7 covers both with room for the instance transform's
// rounding, and stays far below any deliberate smoothing (a normal turned by 1e-3 rad already shades visibly).
constexpr double kFlatNormal = 8 * 0x1.0p-24;

// One top-level Embree geometry: an instance's triangles in world space (flattened), or an Embree instance of its
// mesh's BVH (instanced).
struct Geometry {
  int instance = 0, mesh = 0;
  const MeshAttributes* source = nullptr;
  size_t count = 0;         // its triangles
  size_t first = 0;         // where its triangles start in the record arrays (an instanced mesh's: shared)
  bool instanced = false;   // the records are in object space; to_world maps them to world space
  double normal_matrix[9];  // the inverse transpose of the instance's 3×3 part, row-major (of to_world if instanced)
  double mirror = 1;        // sign of its determinant: −1 flips the winding's normal back outwards
  std::array<double, 4> lightmap_st{1, 1, 0, 0};
  // Instanced only: the transform Embree holds (the instance's, rounded to float; row-major 3×4, exact in double),
  // what the float ray transform adds to a hit's offset (instance_offset), and ‖M‖∞ (for a zero-normal triangle).
  double to_world[12];
  double offset_extra = 0;
  double scale = 1;
};

// An instanced triangle's normal in world space, not normalised: M⁻ᵀ times an object-space normal n.
Vec3 world_normal(const Geometry& g, const double (&n)[3]) {
  const double* M = g.normal_matrix;
  return {M[0] * n[0] + M[1] * n[1] + M[2] * n[2], M[3] * n[0] + M[4] * n[1] + M[5] * n[2],
          M[6] * n[0] + M[7] * n[1] + M[8] * n[2]};
}

Vec3 vertex(const float* vertices, uint32_t i) {
  const float* v = vertices + 3 * static_cast<size_t>(i);
  return {v[0], v[1], v[2]};
}

void init_ray(RTCRay& r, const Ray& ray) {
  r.org_x = static_cast<float>(ray.origin.x);
  r.org_y = static_cast<float>(ray.origin.y);
  r.org_z = static_cast<float>(ray.origin.z);
  r.tnear = 0.0f;  // spawned origins are lifted off their surface instead (ray_offset.h)
  r.dir_x = static_cast<float>(ray.direction.x);
  r.dir_y = static_cast<float>(ray.direction.y);
  r.dir_z = static_cast<float>(ray.direction.z);
  r.time = 0.0f;
  r.tfar = static_cast<float>(ray.tmax);
  r.mask = 0xffffffffu;
  r.id = 0;
  r.flags = 0;
}

void init_ray_hit(RTCRayHit& rh, const Ray& ray) {
  init_ray(rh.ray, ray);
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
}

// A triangle geometry and its vertex and index buffers; released unless attached to a scene.
struct TriangleGeometry {
  RTCGeometry geom = nullptr;
  float* vb = nullptr;
  uint32_t* ib = nullptr;
  TriangleGeometry() = default;
  TriangleGeometry(const TriangleGeometry&) = delete;
  TriangleGeometry& operator=(const TriangleGeometry&) = delete;
  ~TriangleGeometry() {
    if (geom) rtcReleaseGeometry(geom);
  }
  // Commits it and hands it to `s` (which then holds it); its ID there.
  unsigned attach(RTCScene s) {
    rtcCommitGeometry(geom);
    const unsigned id = rtcAttachGeometry(s, geom);
    rtcReleaseGeometry(geom);
    geom = nullptr;
    return id;
  }
};

// Calls take(v, f) for each vertex v of `mesh` placed by `place` (object to the tracer's space) and rounded to
// float, f its three floats; a vertex no triangle uses is replaced by the first one used, since Embree bounds every
// vertex. Throws for a vertex beyond float range, naming `owner` and the `space` it lands in.
template <class Place, class Take>
void for_each_float_vertex(const Mesh& mesh, const Place& place, const std::string& owner, const char* space,
                           Take take) {
  std::vector<uint8_t> used(mesh.positions.size(), 0);
  for (uint32_t i : mesh.indices) used[i] = 1;
  for (size_t v = 0; v < used.size(); ++v) {
    const Vec3 w = place(mesh.positions[used[v] ? v : mesh.indices[0]]);
    const float f[3] = {static_cast<float>(w.x), static_cast<float>(w.y), static_cast<float>(w.z)};
    if (!std::isfinite(f[0]) || !std::isfinite(f[1]) || !std::isfinite(f[2]))
      throw std::invalid_argument("tracer: " + owner + ": vertex " + std::to_string(v) + " lands at (" +
                                  std::to_string(w.x) + ", " + std::to_string(w.y) + ", " + std::to_string(w.z) +
                                  ") in " + space + " space, beyond single precision; scale the scene down");
    take(v, f);
  }
}

}  // namespace

struct Tracer::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  std::vector<Geometry> geometries;  // by top-level Embree geometry ID
  std::vector<int> geometry_of;      // by scene instance: its top-level geometry ID, −1 without triangles
  // By mesh, for instanced meshes: its BVH (null until an instance needs it) and where its object-space records
  // start.
  std::vector<uint8_t> share;  // by mesh: instanced
  std::vector<RTCScene> mesh_scenes;
  std::vector<size_t> mesh_first;
  std::vector<double> mesh_extent;  // its largest float object coordinate (instance_offset)
  RTCSceneFlags scene_flags = RTC_SCENE_FLAG_NONE;
  std::vector<TriangleRecord> records;
  std::vector<TriangleFacts> facts;
  std::vector<TriangleVertices> vertices;
  std::vector<MeshAttributes> meshes;
  const bake::StopCheck* stop = nullptr;
  size_t triangles = 0;          // traced, in world space
  size_t stored_triangles = 0;   // held in the records
  size_t instanced_instances = 0, instanced_meshes = 0;
  size_t side_bytes = 0;                 // the records and the copied UV attributes
  std::atomic<int64_t> embree_bytes{0};  // what Embree holds, from its memory monitor
  Vec3 lower{INFINITY, INFINITY, INFINITY}, upper{-INFINITY, -INFINITY, -INFINITY};
  std::mutex error_mutex;
  std::string error;  // Embree's last message, from its error callback

  // Embree calls this on the failing thread; C callbacks must not throw, so the message waits for check().
  // Embree's build progress; false cancels the build (rtcCommitScene then reports RTC_ERROR_CANCELLED).
  static bool on_progress(void* user, double /*fraction*/) {
    const auto* self = static_cast<const Impl*>(user);
    return !(self->stop && self->stop->requested());
  }

  static void on_error(void* user, RTCError code, const char* message) {
    auto* self = static_cast<Impl*>(user);
    std::lock_guard<std::mutex> lock(self->error_mutex);
    self->error = std::string(error_name(code)) + (message ? std::string(": ") + message : std::string());
  }

  // Embree reports every allocation (bytes > 0) and release (bytes < 0); true lets it proceed.
  static bool on_memory(void* user, ssize_t bytes, bool /*post*/) {
    static_cast<Impl*>(user)->embree_bytes.fetch_add(bytes, std::memory_order_relaxed);
    return true;
  }

  void check(const char* doing) {
    const RTCError code = rtcGetDeviceError(device);
    if (code == RTC_ERROR_NONE) return;
    std::lock_guard<std::mutex> lock(error_mutex);
    throw std::runtime_error(
        std::string("Embree failed while ") + doing + ": " + (error.empty() ? error_name(code) : error) +
        (code == RTC_ERROR_OUT_OF_MEMORY ? " (the scene is too large for this machine's memory)" : ""));
  }

  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    for (RTCScene s : mesh_scenes)
      if (s) rtcReleaseScene(s);
    if (device) rtcReleaseDevice(device);
  }

  // Building, in this order: the constructor's stages.
  void create_scene(const TracerOptions& options);
  void add_instance(const Scene& input, size_t k);
  void add_instanced(const Scene& input, size_t k);
  void commit();
  void commit_scene(RTCScene s, const char* doing);
  void push_records(const Mesh& mesh, const float* vb, const uint32_t* ib, double mirror,
                    const std::vector<Vec3>& normals);
  void new_triangle_geometry(const Mesh& mesh, const std::string& owner, TriangleGeometry& out);
  // Of add_instance.
  void write_world_vertices(const Scene& input, size_t k, float* vb);
  void add_triangles(const Scene& input, size_t k, const float* vb, const uint32_t* ib, unsigned id);
  // Of add_instanced.
  void build_mesh_scene(const Scene& input, size_t k);
  void instance_bounds(const Scene& input, size_t k, const double (&m)[12]);
  void set_geometry(unsigned id, Geometry g);
  void widen_bounds(const float (&f)[3]) {
    lower = {std::min(lower.x, double(f[0])), std::min(lower.y, double(f[1])), std::min(lower.z, double(f[2]))};
    upper = {std::max(upper.x, double(f[0])), std::max(upper.y, double(f[1])), std::max(upper.z, double(f[2]))};
  }

  size_t triangle(unsigned geom_id, unsigned prim_id) const { return geometries[geom_id].first + prim_id; }
  // The top-level geometry a hit belongs to: the instance geometry for a hit inside an instanced mesh.
  static unsigned top_geometry(const RTCHit& hit) {
    return hit.instID[0] != RTC_INVALID_GEOMETRY_ID ? hit.instID[0] : hit.geomID;
  }
  // The offset of a hit on triangle record i of geometry g (Hit::offset).
  double offset_of(const Geometry& g, size_t i) const;
  HitId id_of(const RTCRayHit& rh) const;  // of a hit
  // Inline: it follows every closest-hit query.
  [[gnu::always_inline]] inline void complete(const Ray& ray, unsigned geom_id, unsigned prim_id, float t, float u,
                                              float v, HitDetail detail, Hit& h) const;
};

namespace {

// The instance's 3×3 part M; returns M^-T (row-major) and sign(det M).
double inverse_transpose(const Transform& t, double out[9]) {
  const double a = t.m[0], b = t.m[1], c = t.m[2], d = t.m[4], e = t.m[5], f = t.m[6], g = t.m[8], h = t.m[9],
               i = t.m[10];
  const double det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g);
  // M^-T = cofactor(M) / det.
  const double cof[9] = {e * i - f * h,    -(d * i - f * g), d * h - e * g,     //
                         -(b * i - c * h), a * i - c * g,    -(a * h - b * g),  //
                         b * f - c * e,    -(a * f - c * d), a * e - b * d};
  for (int k = 0; k < 9; ++k) out[k] = cof[k] / det;
  return det < 0 ? -1.0 : 1.0;
}

std::string where(const Scene& scene, size_t instance, int mesh) {
  const std::string& name = scene.meshes[mesh].name;
  return "instance " + std::to_string(instance) + " (mesh " + std::to_string(mesh) +
         (name.empty() ? std::string() : " '" + name + "'") + ")";
}

// Clean input only: check_scene makes it so; say what is wrong otherwise rather than trace garbage.
const char* const kAdvice = "; run scene::check_scene on the scene first and trace its cleaned scene";

void require_clean_instances(const Scene& scene) {
  for (size_t k = 0; k < scene.instances.size(); ++k) {
    const Instance& inst = scene.instances[k];
    if (inst.mesh < 0 || static_cast<size_t>(inst.mesh) >= scene.meshes.size())
      throw std::invalid_argument("tracer: instance " + std::to_string(k) + " refers to mesh " +
                                  std::to_string(inst.mesh) + " of " + std::to_string(scene.meshes.size()) + kAdvice);
    if (!usable_transform(inst.to_world))
      throw std::invalid_argument("tracer: " + where(scene, k, inst.mesh) + " has a singular or non-finite transform" +
                                  kAdvice);
  }
}

void require_clean_mesh(const Mesh& mesh, size_t m) {
  const size_t nv = mesh.positions.size();
  const std::string label = "tracer: mesh " + std::to_string(m) + " '" + mesh.name + "'";
  if (mesh.indices.size() % 3 != 0)
    throw std::invalid_argument(label + " has " + std::to_string(mesh.indices.size()) +
                                " indices, not a multiple of 3" + kAdvice);
  if (!mesh.normals.empty() && mesh.normals.size() != nv)
    throw std::invalid_argument(label + ": normals and positions differ in size" + kAdvice);
  if ((!mesh.uv.empty() && mesh.uv.size() != nv) || (!mesh.lightmap_uv.empty() && mesh.lightmap_uv.size() != nv))
    throw std::invalid_argument(label + ": UVs and positions differ in size" + kAdvice);
  for (size_t i = 0; i < mesh.indices.size(); ++i) {
    const uint32_t v = mesh.indices[i];
    if (v >= nv)
      throw std::invalid_argument(label + " triangle " + std::to_string(i / 3) + ": index " + std::to_string(v) +
                                  " out of range for " + std::to_string(nv) + " vertices" + kAdvice);
    if (!is_finite(mesh.positions[v]))
      throw std::invalid_argument(label + " triangle " + std::to_string(i / 3) + ": vertex " + std::to_string(v) +
                                  " is not finite" + kAdvice);
  }
}

// The mesh's normals in world space (`M` the instance's normal matrix), rounded to float (as the records keep
// them); empty without vertex normals.
std::vector<Vec3> world_normals(const Mesh& mesh, const double (&M)[9]) {
  std::vector<Vec3> out(mesh.normals.empty() ? 0 : mesh.positions.size());
  for (size_t v = 0; v < out.size(); ++v) {
    const Vec3& n = mesh.normals[v];
    out[v] = {static_cast<float>(M[0] * n.x + M[1] * n.y + M[2] * n.z),
              static_cast<float>(M[3] * n.x + M[4] * n.y + M[5] * n.z),
              static_cast<float>(M[6] * n.x + M[7] * n.y + M[8] * n.z)};
  }
  return out;
}

// Triangle t's vertex indices (from the geometry's index buffer `ib`) and world vertex normals.
TriangleVertices triangle_vertices(const uint32_t* ib, size_t t, const std::vector<Vec3>& normals) {
  TriangleVertices tv{};
  for (int j = 0; j < 3; ++j) {
    tv.index[j] = ib[3 * t + j];
    if (normals.empty()) continue;
    const Vec3& n = normals[tv.index[j]];
    tv.n[j][0] = static_cast<float>(n.x);
    tv.n[j][1] = static_cast<float>(n.y);
    tv.n[j][2] = static_cast<float>(n.z);
  }
  return tv;
}

// The place, offset and unit geometric normal of the triangle of float vertices `vb` at `index`.
TriangleRecord triangle_record(const float* vb, const uint32_t (&index)[3], double mirror) {
  TriangleRecord r{};
  for (int j = 0; j < 3; ++j) std::copy(vb + 3 * size_t{index[j]}, vb + 3 * size_t{index[j]} + 3, r.p[j]);
  const Vec3 p0 = vertex(vb, index[0]), p1 = vertex(vb, index[1]), p2 = vertex(vb, index[2]);
  const double offset = self_intersection_offset(p0, p1, p2, p0);
  r.offset = static_cast<float>(offset);
  if (static_cast<double>(r.offset) < offset) r.offset = std::nextafterf(r.offset, INFINITY);  // never below
  const Vec3 c = cross(p1 - p0, p2 - p0);
  const double len = length(c);
  const Vec3 n = len > 0 ? c * (mirror / len) : Vec3{};
  r.ng[0] = n.x;
  r.ng[1] = n.y;
  r.ng[2] = n.z;
  return r;
}

// Whether a triangle of unit normal `n` interpolates its vertex normals (TriangleFacts::interpolate_normals).
bool interpolates_normals(const std::vector<Vec3>& normals, const uint32_t (&index)[3], const Vec3& n) {
  bool interpolate = false;
  for (int j = 0; j < 3 && !normals.empty(); ++j) {
    const Vec3& vn = normals[index[j]];
    const double vl = length(vn);
    // A zero or non-finite vertex normal, or one off the face: interpolate (complete() guards the zero sum).
    if (!(vl > 0) || !std::isfinite(vl) || !(length(vn * (1.0 / vl) - n) <= kFlatNormal)) interpolate = true;
  }
  return interpolate;
}

// ‖A‖∞ of a row-major 3×3 matrix (`stride` between rows: 4 for a 3×4 transform), and of its transpose.
double norm_inf(const double* a, int stride) {
  double n = 0;
  for (int r = 0; r < 3; ++r)
    n = std::max(n, std::fabs(a[r * stride]) + std::fabs(a[r * stride + 1]) + std::fabs(a[r * stride + 2]));
  return n;
}
double norm_inf_transposed(const double (&a)[9]) {
  double n = 0;
  for (int c = 0; c < 3; ++c) n = std::max(n, std::fabs(a[c]) + std::fabs(a[3 + c]) + std::fabs(a[6 + c]));
  return n;
}

// What Embree's float instancing can add to the self-intersection offset of a hit on an instanced mesh, in world
// units. Embree traces an instance by transforming the ray into object space with the inverse of the float transform
// M (inverted in float at commit) and testing the object-space float triangles. Against the world surface we hold
// (M applied in double to the float object vertices) that adds, per coordinate and mapped back to world space by M:
// the rounding of M's float inverse (a few ε·κ(M) relative), the float transform of the origin (γ_3·κ(M) of the
// origin's and the translation's magnitudes), and the difference between our double and Embree's float world
// geometry (ε·‖M‖ of the object coordinates and ε of the translation). Each is at most ~4·ε·κ(M)·S with
// S = ‖M‖∞·(largest object coordinate) + ‖t‖∞ bounding the coordinates involved (the origin sits within a lift of
// the surface), κ(M) = ‖M‖∞‖M⁻¹‖∞ (1 for a rotation); 16·ε·κ(M)·S covers their sum with room to spare. For a
// level 500 m across that is ~0.5 mm, far below a texel, where the flattened bound (ray_offset.cpp) gives ~0.1 mm.
// The offset along the ray's direction does not enter: the triangle test's sign decides from Ng·(v0 − O) alone.
double instance_offset(const Geometry& g, double object_extent) {
  const double scale = norm_inf(g.to_world, 4);
  const double kappa = scale * norm_inf_transposed(g.normal_matrix);  // M⁻¹ = (M⁻ᵀ)ᵀ
  const double translation = std::max({std::fabs(g.to_world[3]), std::fabs(g.to_world[7]), std::fabs(g.to_world[11])});
  return 16 * 0x1.0p-24 * kappa * (scale * object_extent + translation);
}

}  // namespace

void Tracer::Impl::create_scene(const TracerOptions& options) {
  device = rtcNewDevice(nullptr);
  if (!device)
    throw std::runtime_error(std::string("Embree could not create a device: ") +
                             error_name(rtcGetDeviceError(nullptr)) + " (Embree needs an SSE2-capable x86-64 CPU)");
  rtcSetDeviceErrorFunction(device, &Impl::on_error, this);
  rtcSetDeviceMemoryMonitorFunction(device, &Impl::on_memory, this);
  scene = rtcNewScene(device);
  scene_flags = options.robust ? RTC_SCENE_FLAG_ROBUST : RTC_SCENE_FLAG_NONE;
  rtcSetSceneFlags(scene, scene_flags);
  rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_HIGH);
  check("creating the scene");
}

// One Embree geometry for instance k (none for a mesh without triangles), with its triangles' records.
void Tracer::Impl::add_instance(const Scene& input, size_t k) {
  const Instance& inst = input.instances[k];
  const Mesh& mesh = input.meshes[inst.mesh];
  if (mesh.indices.empty()) return;
  if (share[inst.mesh]) {
    add_instanced(input, k);
    return;
  }
  TriangleGeometry tg;
  new_triangle_geometry(mesh, where(input, k, inst.mesh), tg);
  write_world_vertices(input, k, tg.vb);
  std::copy(mesh.indices.begin(), mesh.indices.end(), tg.ib);
  const unsigned id = tg.attach(scene);
  check("adding a geometry");
  add_triangles(input, k, tg.vb, tg.ib, id);
}

// A triangle geometry with buffers for `mesh`'s vertices and triangles, for `owner` (named in errors).
void Tracer::Impl::new_triangle_geometry(const Mesh& mesh, const std::string& owner, TriangleGeometry& out) {
  const size_t nt = mesh.indices.size() / 3, nv = mesh.positions.size();
  out.geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  check("creating a geometry");
  rtcSetGeometryBuildQuality(out.geom, RTC_BUILD_QUALITY_HIGH);
  out.vb = static_cast<float*>(
      rtcSetNewGeometryBuffer(out.geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), nv));
  out.ib = static_cast<uint32_t*>(
      rtcSetNewGeometryBuffer(out.geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), nt));
  if (!out.vb || !out.ib) {
    check("allocating the geometry buffers");
    throw std::runtime_error("Embree returned no geometry buffer for " + owner);
  }
}

// World positions in double, rounded to float once (the float vertices are what the offsets bound).
void Tracer::Impl::write_world_vertices(const Scene& input, size_t k, float* vb) {
  const Instance& inst = input.instances[k];
  const Mesh& mesh = input.meshes[inst.mesh];
  const auto to_world = [&](const Vec3& p) { return inst.to_world.point(p); };
  for_each_float_vertex(mesh, to_world, where(input, k, inst.mesh), "world", [&](size_t v, const float (&f)[3]) {
    std::copy(f, f + 3, vb + 3 * v);
    widen_bounds(f);
  });
}

// The records of a mesh's triangles from the float vertices `vb` and indices `ib` Embree traces (world space for a
// flattened instance, object space for an instanced mesh), `normals` in the same space.
void Tracer::Impl::push_records(const Mesh& mesh, const float* vb, const uint32_t* ib, double mirror,
                                const std::vector<Vec3>& normals) {
  const size_t nt = mesh.indices.size() / 3;
  for (size_t t = 0; t < nt; ++t) {
    if (stop && t % 65536 == 65535) stop->check();
    const TriangleVertices tv = triangle_vertices(ib, t, normals);
    const TriangleRecord r = triangle_record(vb, tv.index, mirror);
    const Vec3 n{r.ng[0], r.ng[1], r.ng[2]};
    TriangleFacts f{};
    f.zero_normal = n.x == 0.0 && n.y == 0.0 && n.z == 0.0;
    f.interpolate_normals = interpolates_normals(normals, tv.index, n);
    f.material = mesh.material.empty() ? 0 : static_cast<int32_t>(mesh.material[t]);
    records.push_back(r);
    facts.push_back(f);
    vertices.push_back(tv);
  }
  side_bytes += nt * (sizeof(TriangleRecord) + sizeof(TriangleFacts) + sizeof(TriangleVertices));
  stored_triangles += nt;
}

void Tracer::Impl::set_geometry(unsigned id, Geometry g) {
  if (geometries.size() <= id) geometries.resize(id + 1);
  geometry_of[g.instance] = static_cast<int>(id);
  triangles += g.count;
  geometries[id] = std::move(g);
}

// The records of instance k's triangles, traced as Embree geometry `id` from the buffers `vb` and `ib`.
void Tracer::Impl::add_triangles(const Scene& input, size_t k, const float* vb, const uint32_t* ib, unsigned id) {
  const Instance& inst = input.instances[k];
  const Mesh& mesh = input.meshes[inst.mesh];
  Geometry g;
  g.instance = static_cast<int>(k);
  g.mesh = inst.mesh;
  g.source = &meshes[inst.mesh];
  g.count = mesh.indices.size() / 3;
  g.first = records.size();
  g.mirror = inverse_transpose(inst.to_world, g.normal_matrix);
  g.lightmap_st = inst.lightmap_scale_offset;
  push_records(mesh, vb, ib, g.mirror, world_normals(mesh, g.normal_matrix));
  set_geometry(id, std::move(g));
}

// Commits a scene (the top level or a mesh's), cancelled by the stop through Embree's progress monitor.
void Tracer::Impl::commit_scene(RTCScene s, const char* doing) {
  if (stop) rtcSetSceneProgressMonitorFunction(s, &Impl::on_progress, this);
  rtcCommitScene(s);
  // A build cancelled by the progress monitor is a stop, not a failure of Embree's.
  if (stop && stop->requested()) {
    rtcGetDeviceError(device);  // clears RTC_ERROR_CANCELLED
    stop->check();
  }
  check(doing);
}

// The BVH of instance k's mesh in object space (its vertices rounded to float), and its records, for every instance
// of the mesh.
void Tracer::Impl::build_mesh_scene(const Scene& input, size_t k) {
  const int m = input.instances[k].mesh;
  const Mesh& mesh = input.meshes[m];
  RTCScene ms = rtcNewScene(device);
  mesh_scenes[m] = ms;  // released with the tracer
  rtcSetSceneFlags(ms, scene_flags);
  rtcSetSceneBuildQuality(ms, RTC_BUILD_QUALITY_HIGH);
  TriangleGeometry tg;
  const std::string owner = where(input, k, m);
  new_triangle_geometry(mesh, owner, tg);
  double extent = 0;
  const auto object = [](const Vec3& p) { return p; };
  for_each_float_vertex(mesh, object, owner, "object", [&](size_t v, const float (&f)[3]) {
    std::copy(f, f + 3, tg.vb + 3 * v);
    extent = std::max({extent, std::fabs(double(f[0])), std::fabs(double(f[1])), std::fabs(double(f[2]))});
  });
  std::copy(mesh.indices.begin(), mesh.indices.end(), tg.ib);
  const float* vb = tg.vb;
  const uint32_t* ib = tg.ib;
  tg.attach(ms);
  check("adding a mesh's geometry");
  mesh_first[m] = records.size();
  mesh_extent[m] = extent;
  const double identity[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  push_records(mesh, vb, ib, 1.0, world_normals(mesh, identity));
  ++instanced_meshes;
  commit_scene(ms, "building a mesh's acceleration structure");
}

// Widens the bounds by instance k's float world vertices under its float transform `m`; throws for a vertex beyond
// float range.
void Tracer::Impl::instance_bounds(const Scene& input, size_t k, const double (&m)[12]) {
  const Instance& inst = input.instances[k];
  // The float object vertex under the float transform, as Embree places it.
  const auto to_world = [&](const Vec3& p) {
    const double x = static_cast<float>(p.x), y = static_cast<float>(p.y), z = static_cast<float>(p.z);
    return Vec3{m[0] * x + m[1] * y + m[2] * z + m[3], m[4] * x + m[5] * y + m[6] * z + m[7],
                m[8] * x + m[9] * y + m[10] * z + m[11]};
  };
  for_each_float_vertex(input.meshes[inst.mesh], to_world, where(input, k, inst.mesh), "world",
                        [&](size_t, const float (&f)[3]) { widen_bounds(f); });
}

// Instance k as an Embree instance of its mesh's BVH (built by its first instance).
void Tracer::Impl::add_instanced(const Scene& input, size_t k) {
  const Instance& inst = input.instances[k];
  const int m = inst.mesh;
  if (!mesh_scenes[m]) build_mesh_scene(input, k);
  Geometry g;
  g.instance = static_cast<int>(k);
  g.mesh = m;
  g.source = &meshes[m];
  g.count = input.meshes[m].indices.size() / 3;
  g.first = mesh_first[m];
  g.instanced = true;
  Transform rounded;
  float xfm[12];
  for (int i = 0; i < 12; ++i) {
    xfm[i] = static_cast<float>(inst.to_world.m[i]);
    g.to_world[i] = rounded.m[i] = xfm[i];
  }
  g.mirror = inverse_transpose(rounded, g.normal_matrix);
  bool finite = true;
  for (int i = 0; i < 12; ++i) finite = finite && std::isfinite(xfm[i]);
  for (double e : g.normal_matrix) finite = finite && std::isfinite(e);
  if (!finite)
    throw std::invalid_argument("tracer: " + where(input, k, m) +
                                " has a transform that is singular or beyond single precision once rounded to float; "
                                "scale the scene down");
  g.lightmap_st = inst.lightmap_scale_offset;
  g.scale = norm_inf(g.to_world, 4);
  g.offset_extra = instance_offset(g, mesh_extent[m]);
  instance_bounds(input, k, g.to_world);
  RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_INSTANCE);
  rtcSetGeometryInstancedScene(geom, mesh_scenes[m]);
  rtcSetGeometryTransform(geom, 0, RTC_FORMAT_FLOAT3X4_ROW_MAJOR, xfm);
  rtcCommitGeometry(geom);
  const unsigned id = rtcAttachGeometry(scene, geom);
  rtcReleaseGeometry(geom);  // the scene holds it
  check("adding an instance");
  ++instanced_instances;
  set_geometry(id, std::move(g));
}

void Tracer::Impl::commit() {
  for (const MeshAttributes& m : meshes) side_bytes += (m.uv.size() + m.lightmap_uv.size()) * sizeof(Point2);
  side_bytes += geometries.size() * sizeof(Geometry) + geometry_of.size() * sizeof(int);
  commit_scene(scene, "building the acceleration structure");
}

Tracer::Tracer(const Scene& scene, const TracerOptions& options) : impl_(std::make_unique<Impl>()) {
  require_clean_instances(scene);
  for (size_t m = 0; m < scene.meshes.size(); ++m) require_clean_mesh(scene.meshes[m], m);
  Impl& im = *impl_;
  im.stop = options.stop;
  im.create_scene(options);
  const size_t nm = scene.meshes.size();
  im.meshes.resize(nm);
  for (size_t m = 0; m < nm; ++m) im.meshes[m] = {scene.meshes[m].uv, scene.meshes[m].lightmap_uv};
  // Which meshes are instanced (TracerOptions::instancing): by the instances that trace them.
  std::vector<size_t> uses(nm, 0);
  for (const Instance& inst : scene.instances)
    if (!scene.meshes[inst.mesh].indices.empty()) ++uses[inst.mesh];
  im.share.resize(nm);
  for (size_t m = 0; m < nm; ++m) im.share[m] = instanced_mesh(options.instancing, uses[m], scene.meshes[m].indices.size() / 3);
  im.mesh_scenes.assign(nm, nullptr);
  im.mesh_first.assign(nm, 0);
  im.mesh_extent.assign(nm, 0);
  im.geometry_of.assign(scene.instances.size(), -1);
  for (size_t k = 0; k < scene.instances.size(); ++k) {
    if (im.stop) im.stop->check();
    im.add_instance(scene, k);
  }
  im.commit();
}

Tracer::~Tracer() = default;
Tracer::Tracer(Tracer&&) noexcept = default;
Tracer& Tracer::operator=(Tracer&&) noexcept = default;

size_t Tracer::triangle_count() const { return impl_->triangles; }
size_t Tracer::stored_triangle_count() const { return impl_->stored_triangles; }
size_t Tracer::instanced_instance_count() const { return impl_->instanced_instances; }
size_t Tracer::instanced_mesh_count() const { return impl_->instanced_meshes; }

bool Tracer::instanced(int instance) const {
  const auto& of = impl_->geometry_of;
  return instance >= 0 && static_cast<size_t>(instance) < of.size() && of[instance] >= 0 &&
         impl_->geometries[of[instance]].instanced;
}

double Tracer::ray_offset(int instance, int triangle) const {
  const auto& of = impl_->geometry_of;
  if (instance < 0 || static_cast<size_t>(instance) >= of.size() || of[instance] < 0)
    throw std::out_of_range("tracer: instance " + std::to_string(instance) + " has no triangles traced");
  const Geometry& g = impl_->geometries[of[instance]];
  if (triangle < 0 || static_cast<size_t>(triangle) >= g.count)
    throw std::out_of_range("tracer: triangle " + std::to_string(triangle) + " of instance " +
                            std::to_string(instance) + " out of range for " + std::to_string(g.count));
  return impl_->offset_of(g, g.first + static_cast<size_t>(triangle));
}
size_t Tracer::memory_bytes() const {
  return static_cast<size_t>(std::max<int64_t>(0, impl_->embree_bytes.load())) + impl_->side_bytes;
}
Vec3 Tracer::bounds_lower() const { return impl_->lower; }
Vec3 Tracer::bounds_upper() const { return impl_->upper; }

double Tracer::Impl::offset_of(const Geometry& g, size_t i) const {
  const TriangleRecord& r = records[i];
  if (!g.instanced) return r.offset;
  // The object-space lift h_o is h_o / |M⁻ᵀ n_o| in world space (a world displacement h·n_w moves h·|M⁻ᵀ n_o| along
  // n_o), plus what the float ray transform adds (instance_offset). A zero normal cannot be hit: ‖M‖ bounds it.
  if (facts[i].zero_normal) return r.offset * g.scale + g.offset_extra;
  return r.offset / length(world_normal(g, r.ng)) + g.offset_extra;
}

inline void Tracer::Impl::complete(const Ray& ray, unsigned geom_id, unsigned prim_id, float t, float hu, float hv,
                                   HitDetail detail, Hit& h) const {
  const size_t i = triangle(geom_id, prim_id);
  const TriangleRecord& r = records[i];
  const TriangleFacts& f = facts[i];
  const Geometry& g = geometries[geom_id];
  h.t = t;
  h.instance = g.instance;
  h.mesh = g.mesh;
  h.triangle = static_cast<int>(prim_id);
  h.material = f.material;
  h.u = hu;
  h.v = hv;
  const double w = 1.0 - h.u - h.v;
  auto point = [&](const float(&q)[3][3], int c) { return q[0][c] * w + q[1][c] * h.u + q[2][c] * h.v; };
  if (!g.instanced) {
    h.p = {point(r.p, 0), point(r.p, 1), point(r.p, 2)};
    // Embree cannot hit a triangle whose float normal is zero (its determinant is 0); if the double one underflows
    // anyway (stored as zero), face the ray.
    h.ng = f.zero_normal ? -normalize(ray.direction) : Vec3{r.ng[0], r.ng[1], r.ng[2]};
    h.offset = r.offset;
  } else {
    // The object-space point and normals through the instance's (float) transform, in double.
    const double* m = g.to_world;
    const Vec3 q{point(r.p, 0), point(r.p, 1), point(r.p, 2)};
    h.p = {m[0] * q.x + m[1] * q.y + m[2] * q.z + m[3], m[4] * q.x + m[5] * q.y + m[6] * q.z + m[7],
           m[8] * q.x + m[9] * q.y + m[10] * q.z + m[11]};
    if (f.zero_normal) {
      h.ng = -normalize(ray.direction);
      h.offset = r.offset * g.scale + g.offset_extra;
    } else {
      const Vec3 n = world_normal(g, r.ng);
      const double len = length(n);
      h.ng = n * (1.0 / len);
      h.offset = r.offset / len + g.offset_extra;
    }
  }
  h.front_face = dot(ray.direction, h.ng) < 0;
  h.ns = h.ng;
  if (f.interpolate_normals) {
    const TriangleVertices& tv = vertices[i];
    Vec3 nw{point(tv.n, 0), point(tv.n, 1), point(tv.n, 2)};
    if (g.instanced) {
      const double o[3] = {nw.x, nw.y, nw.z};
      nw = world_normal(g, o);
    }
    const double nl = length(nw);
    // Opposite vertex normals can interpolate to zero inside the triangle: the geometric normal stands in.
    if (nl > 0 && std::isfinite(nl)) h.ns = nw * ((dot(nw, h.ng) < 0 ? -1.0 : 1.0) / nl);
  }
  h.lightmap_uv = {};
  h.uv = {};
  if (detail.lightmap_uv || detail.uv) {
    const MeshAttributes& mesh = *g.source;
    const TriangleVertices& tv = vertices[i];
    const uint32_t i0 = tv.index[0], i1 = tv.index[1], i2 = tv.index[2];
    if (detail.lightmap_uv && !mesh.lightmap_uv.empty()) {
      const Point2 &a = mesh.lightmap_uv[i0], &b = mesh.lightmap_uv[i1], &d = mesh.lightmap_uv[i2];
      const Point2 q{a.x * w + b.x * h.u + d.x * h.v, a.y * w + b.y * h.u + d.y * h.v};
      h.lightmap_uv = {g.lightmap_st[0] * q.x + g.lightmap_st[2], g.lightmap_st[1] * q.y + g.lightmap_st[3]};
    }
    if (detail.uv && !mesh.uv.empty()) {
      const Point2 &a = mesh.uv[i0], &b = mesh.uv[i1], &d = mesh.uv[i2];
      h.uv = {a.x * w + b.x * h.u + d.x * h.v, a.y * w + b.y * h.u + d.y * h.v};
    }
  }
}

namespace {
// One closest-hit query with its own context (what makes concurrent queries safe); false on a miss.
bool intersect1(RTCScene scene, const Ray& ray, RTCRayHit& rh) {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  init_ray_hit(rh, ray);
  rtcIntersect1(scene, &context, &rh);
  return rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
}

// `r`: the record of the triangle hit, `g` its (top-level) geometry.
HitId make_id(const RTCRayHit& rh, const TriangleRecord& r, const Geometry& g) {
  HitId id;
  id.t = rh.ray.tfar;
  id.instance = g.instance;
  id.triangle = static_cast<int>(rh.hit.primID);
  id.u = rh.hit.u;
  id.v = rh.hit.v;
  // Embree's Ng is (p1 − p0) × (p2 − p0) up to Embree's sign convention, which we do not rely on: ours, stored.
  // An instanced triangle's: M⁻ᵀ times the object normal points the same way as its world normal.
  const Vec3 ng = g.instanced ? world_normal(g, r.ng) : Vec3{r.ng[0], r.ng[1], r.ng[2]};
  id.front_face = ng.x * rh.ray.dir_x + ng.y * rh.ray.dir_y + ng.z * rh.ray.dir_z < 0;
  return id;
}
}  // namespace

HitId Tracer::Impl::id_of(const RTCRayHit& rh) const {
  const unsigned top = top_geometry(rh.hit);
  return make_id(rh, records[triangle(top, rh.hit.primID)], geometries[top]);
}

std::optional<Hit> Tracer::intersect(const Ray& ray, HitDetail detail) const {
  RTCRayHit rh;
  if (!intersect1(impl_->scene, ray, rh)) return std::nullopt;
  Hit h;
  impl_->complete(ray, Impl::top_geometry(rh.hit), rh.hit.primID, rh.ray.tfar, rh.hit.u, rh.hit.v, detail, h);
  return h;
}

bool Tracer::intersect(const Ray& ray, Hit& out, HitDetail detail) const {
  RTCRayHit rh;
  if (!intersect1(impl_->scene, ray, rh)) return false;
  impl_->complete(ray, Impl::top_geometry(rh.hit), rh.hit.primID, rh.ray.tfar, rh.hit.u, rh.hit.v, detail, out);
  return true;
}

std::optional<HitId> Tracer::intersect_id(const Ray& ray) const {
  RTCRayHit rh;
  if (!intersect1(impl_->scene, ray, rh)) return std::nullopt;
  return impl_->id_of(rh);
}

Hit Tracer::complete(const Ray& ray, const HitId& id) const {
  const auto& of = impl_->geometry_of;
  if (id.instance < 0 || static_cast<size_t>(id.instance) >= of.size() || of[id.instance] < 0)
    throw std::invalid_argument("tracer: HitId of instance " + std::to_string(id.instance) + " which has no triangles");
  Hit h;
  impl_->complete(ray, static_cast<unsigned>(of[id.instance]), static_cast<unsigned>(id.triangle),
                  static_cast<float>(id.t), static_cast<float>(id.u), static_cast<float>(id.v), HitDetail{}, h);
  return h;
}

bool Tracer::occluded(const Ray& ray) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay r;
  init_ray(r, ray);
  rtcOccluded1(impl_->scene, &context, &r);
  return r.tfar < 0;  // Embree sets tfar to −inf when it finds any hit
}

namespace {
// Traces `rays` as Embree streams (flagged incoherent) of up to 256 rays, a chunk small enough to stay in L1/L2:
// init(embree_ray, ray) fills one, trace(context, buffer, n) traces a chunk, collect(i, embree_ray) reads one back.
template <class EmbreeRay, class Init, class Trace, class Collect>
void trace_stream(std::span<const Ray> rays, size_t out_size, const char* query, Init init, Trace trace,
                  Collect collect) {
  if (out_size != rays.size())
    throw std::invalid_argument(std::string("tracer: ") + query + " of " + std::to_string(rays.size()) + " rays into " +
                                std::to_string(out_size) + " results");
  constexpr size_t kChunk = 256;
  EmbreeRay buffer[kChunk];
  for (size_t start = 0; start < rays.size(); start += kChunk) {
    const size_t n = std::min(kChunk, rays.size() - start);
    for (size_t i = 0; i < n; ++i) init(buffer[i], rays[start + i]);
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    context.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    trace(&context, buffer, static_cast<unsigned>(n));
    for (size_t i = 0; i < n; ++i) collect(start + i, buffer[i]);
  }
}
}  // namespace

void Tracer::intersect(std::span<const Ray> rays, std::span<std::optional<HitId>> out) const {
  RTCScene scene = impl_->scene;
  const Impl& im = *impl_;
  trace_stream<RTCRayHit>(
      rays, out.size(), "intersect", init_ray_hit,
      [scene](RTCIntersectContext* c, RTCRayHit* b, unsigned n) { rtcIntersect1M(scene, c, b, n, sizeof(RTCRayHit)); },
      [&](size_t i, const RTCRayHit& rh) {
        out[i] = rh.hit.geomID == RTC_INVALID_GEOMETRY_ID ? std::nullopt : std::optional<HitId>(im.id_of(rh));
      });
}

void Tracer::occluded(std::span<const Ray> rays, std::span<uint8_t> out) const {
  RTCScene scene = impl_->scene;
  trace_stream<RTCRay>(
      rays, out.size(), "occluded", init_ray,
      [scene](RTCIntersectContext* c, RTCRay* b, unsigned n) { rtcOccluded1M(scene, c, b, n, sizeof(RTCRay)); },
      [&](size_t i, const RTCRay& r) { out[i] = r.tfar < 0 ? 1 : 0; });
}

}  // namespace kiln::scene
