// The lightmap job's part of the translation layer: a kiln.v1.LightmapJob in, a lightmap::LightmapBakeInput out,
// every field checked against the bounds kiln.proto documents and named by its path when it is not
// ("job.lightmap.lights[0].spot.outer_cone_angle"). Mesh blobs are decoded later, in the worker (load_inputs).
#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <sstream>

#include "bakers/bake/number_format.h"
#include "bakers/lightmap/memory_estimate.h"
#include "bakers/scene/scene_check.h"
#include "bakers/volume/vdb_file.h"
#include "daemon/mesh_blob_decode.h"
#include "daemon/store/blob_store.h"
#include "daemon/translate_fields.h"
#include "proto/digest.h"
#include "proto/kiln.pb.h"

#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>

namespace kiln::daemon::detail {
namespace {

using bake::format_number;

constexpr std::size_t kMaxNameBytes = 256;
constexpr int kMaxMeshes = 65536;
constexpr int kMaxInstances = 1 << 20;
constexpr int kMaxMaterials = 65536;
constexpr int kMaxTextures = 4096;
constexpr int kMaxLights = 65536;
constexpr int kMaxLightmapSettings = 65536;
// 16 pages of 4096²: a bake that does not fit its memory limit whole samples them a tile at a time, holding ~40
// bytes a texel of the page being baked (bakers/lightmap/lightmap_results.h).
constexpr uint64_t kMaxTotalTexels = uint64_t{1} << 28;
constexpr double kMaxCoordinate = 1e9;                   // beyond it float32 geometry has no precision left
constexpr bounds::Range kCoordinate{-kMaxCoordinate, kMaxCoordinate};
constexpr double kMaxLightColor = 1e12;
constexpr double kMaxEmission = 1e9;
constexpr uint64_t kDefaultMinSamples = 16;  // the baker's default, capped by max_samples
constexpr uint64_t kDefaultMaxPages = 4;     // atlas pages, fewer where the texel limit says so
constexpr double kHalfPi = 1.5707963267948966;

std::string at(const std::string& path, int i) { return path + "[" + std::to_string(i) + "]"; }

void check_name(const std::string& name, const std::string& field) {
  if (name.size() > kMaxNameBytes) {
    throw InvalidField(field, "at most 256 bytes, got " + std::to_string(name.size()));
  }
}

void check_count(int n, int most, const std::string& field, const char* what) {
  if (n > most) {
    throw InvalidField(field, "at most " + std::to_string(most) + " " + what + ", got " + std::to_string(n));
  }
}

Vec3 vector(const kiln::v1::Vector3& v, const std::string& field) {
  check_range(field + ".x", v.x(), kCoordinate);
  check_range(field + ".y", v.y(), kCoordinate);
  check_range(field + ".z", v.z(), kCoordinate);
  return {v.x(), v.y(), v.z()};
}

// A direction: finite and non-zero (a zero vector has no direction to normalise).
Vec3 direction(const kiln::v1::Vector3& v, const std::string& field, bool given) {
  if (!given) throw InvalidField(field, "required: a non-zero direction");
  const Vec3 d = vector(v, field);
  const double length = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
  if (!(length > 0)) throw InvalidField(field, "must be non-zero, got (0, 0, 0)");
  return {d.x / length, d.y / length, d.z / length};
}

scene::Light point_light(const kiln::v1::PointLight& pt, const std::string& p, scene::Light out) {
  out.type = scene::LightShape::point;
  out.position = vector(pt.position(), p + ".position");
  return out;
}

scene::Light spot_light(const kiln::v1::SpotLight& s, const std::string& p, scene::Light out) {
  out.type = scene::LightShape::spot;
  out.position = vector(s.position(), p + ".position");
  out.direction = direction(s.direction(), p + ".direction", s.has_direction());
  if (s.has_outer_cone_angle()) {
    check_range(p + ".outer_cone_angle", s.outer_cone_angle(), bounds::Range{0.0, kHalfPi, true});
    out.outer_cone = s.outer_cone_angle();
  }
  if (s.has_inner_cone_angle()) {
    check_range(p + ".inner_cone_angle", s.inner_cone_angle(), bounds::Range{0.0, out.outer_cone});
    out.inner_cone = s.inner_cone_angle();
  }
  return out;
}

scene::Light directional_light(const kiln::v1::DirectionalLight& d, const std::string& p, scene::Light out) {
  out.type = scene::LightShape::directional;
  out.direction = direction(d.direction(), p + ".direction", d.has_direction());
  out.angular_diameter = 0.00935;  // the sun's, as kiln.proto documents
  if (d.has_angular_diameter()) {
    check_range(p + ".angular_diameter", d.angular_diameter(), bounds::Range{0.0, 0.5});
    out.angular_diameter = d.angular_diameter();
  }
  return out;
}

scene::Light rect_light(const kiln::v1::RectLight& r, const std::string& p, scene::Light out) {
  out.type = scene::LightShape::rect;
  out.position = vector(r.center(), p + ".center");
  out.u_axis = vector(r.u(), p + ".u");
  out.v_axis = vector(r.v(), p + ".v");
  const Vec3 n = cross(out.u_axis, out.v_axis);
  const double area = std::sqrt(dot(n, n));
  // Parallel or zero edges span no area: the light would emit nothing from nowhere.
  if (!(area > 0) || !std::isfinite(area)) {
    throw InvalidField(p + ".v", "u and v must span a rectangle (non-zero, not parallel)");
  }
  out.direction = n / area;
  out.two_sided = r.two_sided();
  return out;
}

scene::Light disk_light(const kiln::v1::DiskLight& d, const std::string& p, scene::Light out) {
  out.type = scene::LightShape::disk;
  out.position = vector(d.center(), p + ".center");
  out.direction = direction(d.normal(), p + ".normal", d.has_normal());
  check_range(p + ".radius", d.radius(), bounds::Range{0.0, 1e6, true});
  out.radius = d.radius();
  out.two_sided = d.two_sided();
  return out;
}

scene::Light light(const kiln::v1::Light& l, const std::string& path) {
  scene::Light out;
  check_name(l.name(), path + ".name");
  out.name = l.name();
  if (l.has_color()) out.color = color(l.color(), path + ".color", bounds::Range{0.0, kMaxLightColor});
  using L = kiln::v1::Light;
  switch (l.type_case()) {
    case L::kPoint:
      return point_light(l.point(), path + ".point", std::move(out));
    case L::kSpot:
      return spot_light(l.spot(), path + ".spot", std::move(out));
    case L::kDirectional:
      return directional_light(l.directional(), path + ".directional", std::move(out));
    case L::kRect:
      return rect_light(l.rect(), path + ".rect", std::move(out));
    case L::kDisk:
      return disk_light(l.disk(), path + ".disk", std::move(out));
    case L::TYPE_NOT_SET:
      break;
  }
  throw InvalidField(path, "no light type given: set point, spot, directional, rect or disk");
}

// A material of the scene; Lambert 0.8 with no specular lobe when it gives no BSDF.
scene::SceneMaterial material(const kiln::v1::SceneMaterial& m, const std::string& path, int textures) {
  scene::SceneMaterial out;
  check_name(m.name(), path + ".name");
  out.name = m.name();
  out.bsdf = material_spec(m.bsdf(), path + ".bsdf");
  if (m.has_base_color()) out.base_color = color(m.base_color(), path + ".base_color", bounds::kReflectance);
  if (m.has_base_color_texture()) {
    if (m.base_color_texture() >= static_cast<uint32_t>(textures)) {
      throw InvalidField(path + ".base_color_texture", "index " + std::to_string(m.base_color_texture()) +
                                                           " out of range: the job has " + std::to_string(textures) +
                                                           " textures");
    }
    out.base_color_texture = static_cast<int>(m.base_color_texture());
  }
  if (m.has_emission()) out.emission = color(m.emission(), path + ".emission", bounds::Range{0.0, kMaxEmission});
  out.two_sided = m.two_sided();
  return out;
}

void environment(const kiln::v1::SceneEnvironment& e, const std::string& path, const store::BlobStore* blobs,
                 BakeRequest& r) {
  lightmap::LightmapBakeInput& in = r.lightmap();
  using E = kiln::v1::SceneEnvironment;
  double intensity = 1;
  if (e.has_intensity()) {
    check_range(path + ".intensity", e.intensity(), bounds::kEnvironmentIntensity);
    intensity = e.intensity();
  }
  switch (e.source_case()) {
    case E::kConstant: {
      const Rgb c = color(e.constant(), path + ".constant", bounds::kEnvironmentConstant);
      if (!e.color_space().empty()) {
        throw InvalidField(path + ".color_space",
                           "applies to an image; a constant colour is already radiance in "
                           "the working space: leave it out");
      }
      if (e.rotation_degrees() != 0) {
        throw InvalidField(path + ".rotation_degrees",
                           "a constant environment has no direction to rotate: leave "
                           "it out");
      }
      in.scene.environment.constant = Rgb{c.r * intensity, c.g * intensity, c.b * intensity};
      break;
    }
    case E::kImage:
      r.inputs.push_back(input_blob(e.image(), path + ".image", blobs));
      if (!e.color_space().empty()) check_color_space(e.color_space(), path + ".color_space");
      check_range(path + ".rotation_degrees", e.rotation_degrees(), bounds::kRotationDegrees);
      in.environment_decode.color_space = e.color_space();
      in.environment_decode.rotation_degrees = e.rotation_degrees();
      in.environment_decode.intensity = intensity;
      break;
    case E::SOURCE_NOT_SET:
      throw InvalidField(path,
                         "no environment given: set constant (a colour) or image (an uploaded "
                         "equirectangular image), or leave the environment out for none");
  }
}

const std::string kPath = "job.lightmap";

// ---- Participating media ----

// An axis-aligned box: both corners given and finite, lo ≤ hi on every axis.
volume::Bounds3 medium_box(const kiln::v1::MediumBox& b, const std::string& p) {
  if (!b.has_lo()) throw InvalidField(p + ".lo", "required: the box's lowest corner");
  if (!b.has_hi()) throw InvalidField(p + ".hi", "required: the box's highest corner");
  const volume::Bounds3 box{vector(b.lo(), p + ".lo"), vector(b.hi(), p + ".hi")};
  if (box.empty()) {
    throw InvalidField(p + ".hi", "must be at least lo on every axis, got lo (" + format_number(box.lo.x) + ", " +
                                      format_number(box.lo.y) + ", " + format_number(box.lo.z) + "), hi (" +
                                      format_number(box.hi.x) + ", " + format_number(box.hi.y) + ", " +
                                      format_number(box.hi.z) + ")");
  }
  return box;
}

// A VDB medium's placement: 0 or 12 values, each within the coordinate bound, and invertible.
scene::Transform medium_transform(const kiln::v1::VdbMedium& v, const std::string& p) {
  scene::Transform t;
  if (v.transform_size() == 0) return t;
  if (v.transform_size() != 12) {
    throw InvalidField(p,
                       "0 or 12 values (a row-major 3x4 affine transform), got " + std::to_string(v.transform_size()));
  }
  for (int k = 0; k < 12; ++k) {
    check_range(at(p, k), v.transform(k), kCoordinate);
    t.m[k] = v.transform(k);
  }
  if (!scene::usable_transform(t)) throw InvalidField(p, "is singular: the medium would have no volume");
  return t;
}

// The grids' names: the density's (default "density") and the emission's (optional, another grid).
void grid_names(const kiln::v1::VdbMedium& v, const std::string& p, volume::MediumInput& out) {
  check_name(v.density_grid(), p + ".density_grid");
  check_name(v.emission_grid(), p + ".emission_grid");
  if (!v.density_grid().empty()) out.density_grid = v.density_grid();
  out.emission_grid = v.emission_grid();
  if (out.emission_grid == out.density_grid) {
    throw InvalidField(p + ".emission_grid", "names the density grid '" + out.density_grid +
                                                 "'; the emission is a grid of its own (or leave it out)");
  }
}

// A density grid from a VDB blob, read by the worker (load_lightmap_inputs).
void vdb_medium(const kiln::v1::Medium& m, const std::string& p, const store::BlobStore* blobs, BakeRequest& r,
                volume::MediumInput& out) {
  const kiln::v1::VdbMedium& v = m.vdb();
  if (!v.has_file()) throw InvalidField(p + ".file", "required: the digest of the uploaded .vdb file");
  BlobRef ref = input_blob(v.file(), p + ".file", blobs);
  if (ref.size > static_cast<uint64_t>(bounds::kVdbBytes.hi)) {
    throw InvalidField(p + ".file", "at most " + std::to_string(bounds::kVdbBytes.hi >> 20) + " MiB, got " +
                                        std::to_string(ref.size) + " bytes");
  }
  r.inputs.push_back(std::move(ref));
  grid_names(v, p, out);
  volume::GridMediumSpec spec;
  spec.to_world = medium_transform(v, p + ".transform");
  // With an emission grid and no colour, the grid holds the radiance itself.
  spec.Le_scale = Rgb{v.emission_grid().empty() || m.has_emission() ? 0.0 : 1.0};
  out.spec = std::move(spec);
}

// The region: fog everywhere, a box, or a grid.
void medium_region(const kiln::v1::Medium& m, const std::string& p, const store::BlobStore* blobs, BakeRequest& r,
                   volume::MediumInput& out) {
  using M = kiln::v1::Medium;
  switch (m.region_case()) {
    case M::kFog:
      if (!m.fog()) throw InvalidField(p + ".fog", "false is no region: true fills the scene, or give box or vdb");
      out.spec = volume::HomogeneousMediumSpec{};
      return;
    case M::kBox: {
      volume::HomogeneousMediumSpec spec;
      spec.box = medium_box(m.box(), p + ".box");
      out.spec = spec;
      return;
    }
    case M::kVdb:
      return vdb_medium(m, p + ".vdb", blobs, r, out);
    case M::REGION_NOT_SET:
      break;
  }
  throw InvalidField(p, "no region given: set fog (true: everywhere), box (lo, hi) or vdb (an uploaded .vdb file)");
}

// One medium: its region, then the coefficients, phase asymmetry and emission every kind has.
volume::MediumInput medium(const kiln::v1::Medium& m, const std::string& p, const store::BlobStore* blobs,
                           BakeRequest& r) {
  volume::MediumInput out;
  check_name(m.name(), p + ".name");
  out.name = m.name();
  medium_region(m, p, blobs, r, out);
  const Rgb sigma_a = m.has_sigma_a() ? color(m.sigma_a(), p + ".sigma_a", bounds::kMediumCoefficient) : Rgb{};
  const Rgb sigma_s = m.has_sigma_s() ? color(m.sigma_s(), p + ".sigma_s", bounds::kMediumCoefficient) : Rgb{};
  check_range(p + ".g", m.g(), bounds::kMediumAsymmetry);
  const std::optional<Rgb> emission =
      m.has_emission() ? std::optional(color(m.emission(), p + ".emission", bounds::kMediumEmission)) : std::nullopt;
  auto fill = [&](auto& spec) {
    spec.sigma_a = sigma_a;
    spec.sigma_s = sigma_s;
    spec.g = m.g();
  };
  if (auto* h = std::get_if<volume::HomogeneousMediumSpec>(&out.spec)) {
    fill(*h);
    if (emission) h->Le = *emission;
  } else {
    auto& g = std::get<volume::GridMediumSpec>(out.spec);
    fill(g);
    if (emission) g.Le_scale = *emission;
  }
  return out;
}

void media(const kiln::v1::LightmapJob& j, const store::BlobStore* blobs, BakeRequest& r) {
  check_count(j.media_size(), static_cast<int>(bounds::kLightmapMedia.hi), kPath + ".media", "media");
  for (int i = 0; i < j.media_size(); ++i) {
    r.lightmap().media.push_back(medium(j.media(i), at(kPath + ".media", i), blobs, r));
  }
}

// The grids of the VDB blob at `ref` (a medium's vdb.file) into its medium; a blob that does not read, or lacks or
// misrepresents a grid, is the blob's field at fault.
void load_vdb_grids(const BlobRef& ref, const std::string& bytes, volume::MediumInput& m) {
  std::vector<std::string> names{m.density_grid};
  if (!m.emission_grid.empty()) names.push_back(m.emission_grid);
  std::vector<volume::VdbGrid> grids;
  try {
    grids = volume::read_vdb({reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()}, names);
  } catch (const bake::InvalidInput& e) {
    throw InvalidField(ref.field, e.field() == "bytes" ? e.problem() : e.field() + ": " + e.problem());
  }
  auto& spec = std::get<volume::GridMediumSpec>(m.spec);
  spec.density = grids[0];
  if (grids.size() > 1) spec.emission = grids[1];
}

// The index in "job.lightmap.meshes[12].geometry".
std::size_t index_in(const std::string& field) { return std::stoul(field.substr(field.find('[') + 1)); }

void check_counts(const kiln::v1::LightmapJob& j) {
  check_count(j.meshes_size(), kMaxMeshes, kPath + ".meshes", "meshes");
  check_count(j.instances_size(), kMaxInstances, kPath + ".instances", "instances");
  check_count(j.materials_size(), kMaxMaterials, kPath + ".materials", "materials");
  check_count(j.textures_size(), kMaxTextures, kPath + ".textures", "textures");
  check_count(j.lights_size(), kMaxLights, kPath + ".lights", "lights");
  check_count(j.material_overrides_size(), kMaxMaterials, kPath + ".material_overrides", "overrides");
  check_count(j.lightmaps_size(), kMaxLightmapSettings, kPath + ".lightmaps", "lightmap settings");
  if (j.meshes_size() == 0) throw InvalidField(kPath + ".meshes", "a scene needs at least one mesh");
}

// Meshes: names now, geometry decoded by the worker.
void meshes(const kiln::v1::LightmapJob& j, const store::BlobStore* blobs, BakeRequest& r, scene::Scene& sc) {
  std::set<std::string> mesh_names;
  for (int i = 0; i < j.meshes_size(); ++i) {
    const kiln::v1::Mesh& m = j.meshes(i);
    const std::string p = at(kPath + ".meshes", i);
    check_name(m.name(), p + ".name");
    if (m.name().empty()) throw InvalidField(p + ".name", "required: a mesh's name names its lightmap");
    if (!mesh_names.insert(m.name()).second) {
      throw InvalidField(p + ".name", "'" + m.name() + "' is the name of an earlier mesh; names are unique");
    }
    if (!m.has_geometry()) throw InvalidField(p + ".geometry", "required: the mesh blob's digest");
    r.inputs.push_back(input_blob(m.geometry(), p + ".geometry", blobs));
    sc.meshes.emplace_back().name = m.name();
  }
}

// Textures: the baker decodes their bytes.
void textures(const kiln::v1::LightmapJob& j, const store::BlobStore* blobs, BakeRequest& r,
              lightmap::LightmapBakeInput& in) {
  for (int i = 0; i < j.textures_size(); ++i) {
    const kiln::v1::Texture& t = j.textures(i);
    const std::string p = at(kPath + ".textures", i);
    check_name(t.name(), p + ".name");
    if (!t.color_space().empty()) check_color_space(t.color_space(), p + ".color_space");
    if (!t.has_image()) throw InvalidField(p + ".image", "required: the image blob's digest");
    r.inputs.push_back(input_blob(t.image(), p + ".image", blobs));
    in.textures.push_back({t.name().empty() ? "texture " + std::to_string(i) : t.name(), {}, t.color_space()});
  }
}

// The scene's materials; their index by name, for the overrides.
std::map<std::string, int> materials(const kiln::v1::LightmapJob& j, scene::Scene& sc) {
  std::map<std::string, int> material_index;
  for (int i = 0; i < j.materials_size(); ++i) {
    const std::string p = at(kPath + ".materials", i);
    sc.materials.push_back(material(j.materials(i), p, j.textures_size()));
    const std::string& name = j.materials(i).name();
    if (!name.empty() && !material_index.emplace(name, i).second) {
      throw InvalidField(p + ".name", "'" + name + "' is the name of an earlier material; names are unique");
    }
  }
  return material_index;
}

// The materials' names, for a message: the first ones, up to about 400 bytes.
std::string material_names(const std::map<std::string, int>& material_index) {
  std::string known;
  for (const auto& [name, index] : material_index) {
    if (known.size() > 400) {
      known += ", ...";
      break;
    }
    known += (known.empty() ? "" : ", ") + name;
  }
  return known.empty() ? "(none named)" : known;
}

// The job's overrides of the scene's materials, by name.
void material_overrides(const kiln::v1::LightmapJob& j, const std::map<std::string, int>& material_index,
                        scene::Scene& sc) {
  std::set<std::string> overridden;
  for (int i = 0; i < j.material_overrides_size(); ++i) {
    const kiln::v1::MaterialOverride& o = j.material_overrides(i);
    const std::string p = at(kPath + ".material_overrides", i);
    check_name(o.name(), p + ".name");
    const auto it = material_index.find(o.name());
    if (it == material_index.end()) {
      throw InvalidField(p + ".name", "no material named '" + o.name() +
                                          "' in the scene; its materials: " + material_names(material_index));
    }
    if (!overridden.insert(o.name()).second) {
      throw InvalidField(p + ".name", "'" + o.name() + "' is overridden twice");
    }
    scene::SceneMaterial& m = sc.materials[it->second];
    if (o.has_bsdf()) m.bsdf = material_spec(o.bsdf(), p + ".bsdf");
    if (o.has_base_color()) m.base_color = color(o.base_color(), p + ".base_color", bounds::kReflectance);
    if (o.has_emission()) m.emission = color(o.emission(), p + ".emission", bounds::Range{0.0, kMaxEmission});
  }
  if (sc.materials.empty()) {
    // A scene without materials: every triangle is the documented default, Lambert 0.8.
    sc.materials.push_back(material(kiln::v1::SceneMaterial(), kPath + ".materials", 0));
    sc.materials.back().name = "default";
  }
}

// An instance's placement in its lightmap: {s_u, s_v, o_u, o_v}, scales in (0, 1], offsets in [0, 1).
void lightmap_scale_offset(const kiln::v1::Instance& inst, const std::string& p, scene::Instance& out) {
  if (inst.lightmap_scale_offset_size() != 0 && inst.lightmap_scale_offset_size() != 4) {
    throw InvalidField(p + ".lightmap_scale_offset",
                       "0 or 4 values {s_u, s_v, o_u, o_v}, got " + std::to_string(inst.lightmap_scale_offset_size()));
  }
  for (int k = 0; k < inst.lightmap_scale_offset_size(); ++k) {
    const std::string f = at(p + ".lightmap_scale_offset", k);
    if (k < 2) {
      check_range(f, inst.lightmap_scale_offset(k), bounds::Range{0.0, 1.0, true});
    } else {
      check_range(f, inst.lightmap_scale_offset(k), bounds::Range{0.0, 1.0});
      if (inst.lightmap_scale_offset(k) >= 1.0) throw InvalidField(f, "an offset is in [0, 1), got 1");
    }
    out.lightmap_scale_offset[k] = inst.lightmap_scale_offset(k);
  }
}

scene::Instance instance(const kiln::v1::Instance& inst, const std::string& p, int meshes) {
  scene::Instance out;
  if (inst.mesh() >= static_cast<uint32_t>(meshes)) {
    throw InvalidField(p + ".mesh", "index " + std::to_string(inst.mesh()) + " out of range: the job has " +
                                        std::to_string(meshes) + " meshes");
  }
  out.mesh = static_cast<int>(inst.mesh());
  if (inst.transform_size() != 0 && inst.transform_size() != 12) {
    throw InvalidField(p + ".transform", "0 or 12 values (a row-major 3x4 affine transform), got " +
                                             std::to_string(inst.transform_size()));
  }
  for (int k = 0; k < inst.transform_size(); ++k) {
    check_range(at(p + ".transform", k), inst.transform(k), kCoordinate);
    out.to_world.m[k] = inst.transform(k);
  }
  check_name(inst.lightmap(), p + ".lightmap");
  out.lightmap = inst.lightmap();
  check_name(inst.name(), p + ".name");
  out.name = inst.name();
  lightmap_scale_offset(inst, p, out);
  out.bake = !inst.has_bake() || inst.bake();
  return out;
}

// Instances; none: every mesh once, where it is. Returns the names of the lightmaps they bake into.
std::set<std::string> instances(const kiln::v1::LightmapJob& j, scene::Scene& sc) {
  std::set<std::string> lightmap_names;
  for (int i = 0; i < j.instances_size(); ++i) {
    const scene::Instance& out =
        sc.instances.emplace_back(instance(j.instances(i), at(kPath + ".instances", i), j.meshes_size()));
    if (out.bake) lightmap_names.insert(out.lightmap.empty() ? j.meshes(out.mesh).name() : out.lightmap);
  }
  if (j.instances_size() == 0) {
    for (int i = 0; i < j.meshes_size(); ++i) {
      scene::Instance& out = sc.instances.emplace_back();
      out.mesh = i;
      lightmap_names.insert(j.meshes(i).name());
    }
  }
  return lightmap_names;
}

void lights(const kiln::v1::LightmapJob& j, scene::Scene& sc) {
  std::set<std::string> light_names;
  for (int i = 0; i < j.lights_size(); ++i) {
    const std::string p = at(kPath + ".lights", i);
    sc.lights.push_back(light(j.lights(i), p));
    const std::string& name = j.lights(i).name();
    if (!name.empty() && !light_names.insert(name).second) {
      throw InvalidField(p + ".name", "'" + name + "' is the name of an earlier light; names are unique");
    }
  }
}

// The job's resolution and each named lightmap's own.
void resolutions(const kiln::v1::LightmapJob& j, const std::set<std::string>& lightmap_names,
                 lightmap::LightmapBakeInput& in) {
  set_count(j.has_resolution(), j.resolution(), kPath + ".resolution", bounds::kLightmapResolution, in.resolution);
  if (j.has_texel_density() && j.lightmaps_size() > 0) {
    throw InvalidField(at(kPath + ".lightmaps", 0), "per-lightmap settings do not apply when texel_density packs "
                                                    "atlas pages (every page is page_size on a side): leave them out");
  }
  for (int i = 0; i < j.lightmaps_size(); ++i) {
    const kiln::v1::LightmapSettings& l = j.lightmaps(i);
    const std::string p = at(kPath + ".lightmaps", i);
    check_name(l.name(), p + ".name");
    if (!lightmap_names.count(l.name())) {
      throw InvalidField(p + ".name", "no instance bakes into a lightmap named '" + l.name() +
                                          "' (lightmaps are named by Instance.lightmap, else the mesh's name)");
    }
    if (in.resolutions.count(l.name())) throw InvalidField(p + ".name", "'" + l.name() + "' is set twice");
    int resolution = in.resolution;
    set_count(l.has_resolution(), l.resolution(), p + ".resolution", bounds::kLightmapResolution, resolution);
    in.resolutions[l.name()] = resolution;
  }
}

// Atlas pages: the job's density, page size and page limit, and each instance's options; without texel_density the
// others must be left unset, and with it no instance may place itself.
void atlas_settings(const kiln::v1::LightmapJob& j, lightmap::LightmapBakeInput& in) {
  lightmap::AtlasOptions& a = in.atlas;
  if (!j.has_texel_density()) {
    if (j.has_page_size()) throw InvalidField(kPath + ".page_size", "needs texel_density: pages are what it packs");
    if (j.has_max_pages()) throw InvalidField(kPath + ".max_pages", "needs texel_density: pages are what it packs");
    if (j.has_uniform_pages()) {
      throw InvalidField(kPath + ".uniform_pages", "needs texel_density: pages are what it packs");
    }
    for (int i = 0; i < j.instances_size(); ++i) {
      const std::string p = at(kPath + ".instances", i);
      if (j.instances(i).has_texel_density()) {
        throw InvalidField(p + ".texel_density", "needs job.lightmap.texel_density (atlas packing)");
      }
      if (j.instances(i).own_page()) throw InvalidField(p + ".own_page", "needs job.lightmap.texel_density (atlas packing)");
    }
    return;
  }
  check_range(kPath + ".texel_density", j.texel_density(), bounds::kTexelDensity);
  a.texel_density = j.texel_density();
  set_count(j.has_page_size(), j.page_size(), kPath + ".page_size", bounds::kAtlasPageSize, a.page_size);
  const uint64_t page_texels = static_cast<uint64_t>(a.page_size) * static_cast<uint64_t>(a.page_size);
  a.max_pages = static_cast<int>(std::min<uint64_t>(kDefaultMaxPages, kMaxTotalTexels / page_texels));
  set_count(j.has_max_pages(), j.max_pages(), kPath + ".max_pages", bounds::kAtlasMaxPages, a.max_pages);
  a.uniform_pages = j.uniform_pages();
  if (static_cast<uint64_t>(a.max_pages) * page_texels > kMaxTotalTexels) {
    throw InvalidField(kPath + ".max_pages", std::to_string(a.max_pages) + " pages of " + std::to_string(a.page_size) +
                                                 "^2 texels exceed the job's " + std::to_string(kMaxTotalTexels) +
                                                 " texels: at most " +
                                                 std::to_string(kMaxTotalTexels / page_texels) + " at this page_size");
  }
  for (int i = 0; i < j.instances_size(); ++i) {
    const kiln::v1::Instance& inst = j.instances(i);
    const std::string p = at(kPath + ".instances", i);
    if (inst.lightmap_scale_offset_size() > 0) {
      throw InvalidField(p + ".lightmap_scale_offset", "must be empty when texel_density packs atlas pages (the "
                                                       "packer places every instance; lightmaps.json says where)");
    }
    lightmap::AtlasInstanceOptions o;
    if (inst.has_texel_density()) {
      check_range(p + ".texel_density", inst.texel_density(), bounds::kTexelDensity);
      o.texel_density = inst.texel_density();
    }
    o.own_page = inst.own_page();
    if (inst.has_texel_density() || o.own_page) a.instances[static_cast<uint32_t>(i)] = o;
  }
}

// The texel budget over every lightmap the job bakes.
void check_texels(const std::set<std::string>& lightmap_names, const lightmap::LightmapBakeInput& in) {
  if (in.atlas.texel_density > 0) return;  // atlas_settings bounded max_pages × page_size²
  uint64_t texels = 0;
  for (const std::string& name : lightmap_names) {
    const auto it = in.resolutions.find(name);
    const uint64_t n = static_cast<uint64_t>(it == in.resolutions.end() ? in.resolution : it->second);
    texels += n * n;
  }
  if (texels > kMaxTotalTexels) {
    throw InvalidField(kPath + ".resolution", std::to_string(lightmap_names.size()) + " lightmaps of " +
                                                  std::to_string(texels) + " texels in all; at most " +
                                                  std::to_string(kMaxTotalTexels) +
                                                  " (16 x 4096 x 4096): lower the resolution or bake in several jobs");
  }
}

lightmap::ErrorMetric error_metric(kiln::v1::LightmapErrorMetric m) {
  switch (m) {
    case kiln::v1::LIGHTMAP_ERROR_METRIC_DEFAULT:
    case kiln::v1::LIGHTMAP_ERROR_METRIC_LIGHTMAP:
      return lightmap::ErrorMetric::lightmap;
    case kiln::v1::LIGHTMAP_ERROR_METRIC_TEXEL:
      return lightmap::ErrorMetric::texel;
    default:
      throw InvalidField(kPath + ".error_metric", "unknown error metric " + std::to_string(static_cast<int>(m)) +
                                                      ": LIGHTMAP_ERROR_METRIC_LIGHTMAP (1) or _TEXEL (2)");
  }
}

uvgen::GenerateUvs generate_uvs(kiln::v1::GenerateUvs g) {
  switch (g) {
    case kiln::v1::GENERATE_UVS_DEFAULT:
    case kiln::v1::GENERATE_UVS_AUTO:
      return uvgen::GenerateUvs::automatic;
    case kiln::v1::GENERATE_UVS_ALWAYS:
      return uvgen::GenerateUvs::always;
    case kiln::v1::GENERATE_UVS_NEVER:
      return uvgen::GenerateUvs::never;
    default:
      throw InvalidField(kPath + ".generate_uvs", "unknown value " + std::to_string(static_cast<int>(g)) +
                                                      ": GENERATE_UVS_AUTO (1), _ALWAYS (2) or _NEVER (3)");
  }
}

// Padding, bounces, which outputs to write and what the target error measures.
void bake_settings(const kiln::v1::LightmapJob& j, lightmap::LightmapBakeInput& in) {
  set_count(j.has_padding(), j.padding(), kPath + ".padding", bounds::kLightmapPadding, in.padding);
  set_count(j.has_max_bounces(), j.max_bounces(), kPath + ".max_bounces", bounds::kMaxBounces, in.max_bounces);
  in.radiance = j.radiance();
  in.ao = j.ao();
  in.directional = j.directional();
  in.preview = !j.has_preview() || j.preview();
  in.denoise = j.denoise();
  in.stitch_seams = !j.has_stitch_seams() || j.stitch_seams();
  in.error_metric = error_metric(j.error_metric());
  in.generate_uvs = generate_uvs(j.generate_uvs());
  if (j.has_memory_limit_bytes()) {
    const uint64_t limit = j.memory_limit_bytes();
    const bounds::WholeRange range = bounds::kLightmapMemoryLimit;
    if (limit < static_cast<uint64_t>(range.lo) || limit > static_cast<uint64_t>(range.hi)) {
      throw InvalidField(kPath + ".memory_limit_bytes", "must be in [2^26, 2^50] bytes (64 MiB to 1 PiB), got " +
                                                            std::to_string(limit));
    }
    in.memory_limit_bytes = limit;
  }
}

void lightmap_quality(const kiln::v1::Quality& q, lightmap::LightmapBakeInput& in) {
  if (q.has_samples()) {
    check_range("job.quality.samples", static_cast<double>(q.samples()), bounds::kLightmapSamples.real());
    in.max_samples = q.samples();
  }
  in.min_samples = std::min(kDefaultMinSamples, in.max_samples);
  if (q.has_target_error()) {
    check_range("job.quality.target_error", q.target_error(), bounds::kLightmapTargetError);
    in.target_error = q.target_error();
  }
  if (q.has_time_limit_seconds()) {
    check_range("job.quality.time_limit_seconds", q.time_limit_seconds(), bounds::kLightmapTimeLimitSeconds);
    in.time_limit_seconds = q.time_limit_seconds();
  }
  in.seed = q.seed();
}

// The total input: every blob must fit in memory beside the others while the worker bakes.
void check_total_input(const BakeRequest& r) {
  uint64_t total = 0;
  for (const BlobRef& b : r.inputs) total += b.size;
  if (total > kMaxJobInputBytes) {
    throw InvalidField(kPath, "the job's blobs hold " + std::to_string(total) + " bytes in all; at most " +
                                  std::to_string(kMaxJobInputBytes >> 30) + " GiB: split the scene into several jobs");
  }
}

// The bake's peak memory by the baker's model (bakers/lightmap/memory_estimate.h), from the spec alone: a mesh's
// triangles are bounded by its blob's size (each needs 12 bytes of indices), every instance traces its mesh's, and the
// tracer holds a mesh shared by many instances once.
void estimate_memory(const kiln::v1::LightmapJob& j, const std::set<std::string>& lightmap_names, BakeRequest& r) {
  const lightmap::LightmapBakeInput& in = r.lightmap();
  // Streamed: the worker stores each output as the bake hands it over (daemon/workers.cpp).
  lightmap::LightmapJobSize size = lightmap::output_size(in, true);
  std::vector<uint64_t> mesh_triangles(static_cast<size_t>(j.meshes_size()), 0);
  for (int i = 0; i < j.meshes_size(); ++i) {
    const uint64_t bytes = j.meshes(i).geometry().size();
    mesh_triangles[i] = bytes > 20 ? (bytes - 20) / 12 : 0;
    size.mesh_blob_bytes += bytes;
  }
  lightmap::count_triangles(mesh_triangles, in.scene.instances, size);
  for (int i = 0; i < j.textures_size(); ++i) size.texture_blob_bytes += j.textures(i).image().size();
  if (j.has_environment() && j.environment().has_image()) size.environment_blob_bytes = j.environment().image().size();
  // The largest lightmap, and the field that sets its resolution.
  std::string largest_field = kPath + ".resolution";
  uint64_t largest = 0, texels = 0;
  const bool packing = in.atlas.texel_density > 0;
  if (packing) {
    // Atlas pages: as many as the job allows, every one whole (the charts are not known before the bake).
    const uint64_t page = static_cast<uint64_t>(in.atlas.page_size) * static_cast<uint64_t>(in.atlas.page_size);
    size.lightmap_texels.assign(static_cast<size_t>(in.atlas.max_pages), page);
    texels = page * static_cast<uint64_t>(in.atlas.max_pages);
    largest_field = kPath + (j.has_max_pages() ? ".max_pages" : ".page_size");
  }
  for (const std::string& name : packing ? std::set<std::string>() : lightmap_names) {
    const auto it = in.resolutions.find(name);
    const uint64_t n = static_cast<uint64_t>(it == in.resolutions.end() ? in.resolution : it->second);
    size.lightmap_texels.push_back(n * n);
    texels += n * n;
    if (n * n <= largest) continue;
    largest = n * n;
    largest_field = kPath + ".resolution";
    for (int i = 0; i < j.lightmaps_size(); ++i) {
      if (j.lightmaps(i).name() == name && j.lightmaps(i).has_resolution()) {
        largest_field = at(kPath + ".lightmaps", i) + ".resolution";
      }
    }
  }
  LightmapMemoryBasis basis;
  basis.size = size;
  basis.texel_field = largest_field;
  basis.scene_field = kPath + (j.instances_size() > 0 ? ".instances" : ".meshes");
  basis.input_field = kPath + (size.texture_blob_bytes >= size.environment_blob_bytes ? ".textures" : ".environment");
  basis.lightmaps = packing ? size.lightmap_texels.size() : lightmap_names.size();
  basis.pages = packing;
  basis.texels = texels;
  if (in.probes.enabled()) basis.probe_field = kPath + ".probes.max_probes";
  r.lightmap_memory = basis;
  plan_lightmap_memory(r, in.memory_limit_bytes);
}

}  // namespace

void plan_lightmap_memory(BakeRequest& r, uint64_t limit) {
  lightmap::LightmapBakeInput& in = r.lightmap();
  const LightmapMemoryBasis& basis = *r.lightmap_memory;
  const lightmap::LightmapJobSize& size = basis.size;
  const lightmap::LightmapMemoryEstimate e = lightmap::plan_memory(size, limit);
  // The bake runs in exactly the tiles the estimate was made for.
  in.memory_limit_bytes = limit;
  in.tile_size = e.tile_size;
  const std::string& largest_field = basis.texel_field;
  const uint64_t texels = basis.texels;
  uint64_t texel_bytes = 0;
  for (uint64_t b : e.lightmap_bytes) texel_bytes += b;
  r.memory_bytes = e.total;
  // The part that costs most names the field to lower: for the media, the file of the largest.
  size_t largest_medium = 0;
  for (size_t i = 1; i < e.medium_bytes.size(); ++i) {
    if (e.medium_bytes[i] > e.medium_bytes[largest_medium]) largest_medium = i;
  }
  if (e.media_bytes > std::max({texel_bytes, e.scene_bytes, e.input_bytes, e.probe_bytes})) {
    r.memory_field = basis.vdb_media_fields.at(largest_medium);
  } else if (!basis.probe_field.empty() && e.probe_bytes >= std::max({texel_bytes, e.scene_bytes, e.input_bytes})) {
    r.memory_field = basis.probe_field;
  } else if (texel_bytes >= e.scene_bytes && texel_bytes >= e.input_bytes) {
    r.memory_field = largest_field;
  } else if (e.scene_bytes >= e.input_bytes) {
    r.memory_field = basis.scene_field;
  } else {
    r.memory_field = basis.input_field;
  }
  const std::string tiles =
      e.tile_size > 0 ? " in tiles of " + std::to_string(e.tile_size) + "x" + std::to_string(e.tile_size) + " (" +
                            std::to_string(static_cast<uint64_t>(e.bytes_per_texel_in_flight)) +
                            " bytes a texel in flight, " +
                            std::to_string(static_cast<uint64_t>(e.results_bytes_per_texel)) + " a texel of a page)"
                      : " at about " + std::to_string(static_cast<uint64_t>(e.bytes_per_texel)) + " bytes each";
  r.memory_note = std::to_string(basis.lightmaps) + (basis.pages ? " atlas page(s) of " : " lightmap(s) of ") + std::to_string(texels) + " texels in all" +
                  tiles + " (" + lightmap::format_bytes(texel_bytes) + "), up to " +
                  std::to_string(size.traced_triangles) + " traced triangles (" + lightmap::format_bytes(e.scene_bytes) +
                  " with the meshes), inputs " + lightmap::format_bytes(e.input_bytes);
  if (size.probes > 0) {
    r.memory_note += ", up to " + std::to_string(size.probes) + " light probes (" + lightmap::format_bytes(e.probe_bytes) + ")";
  }
  if (!size.vdb_media.empty()) {
    r.memory_note += ", " + std::to_string(size.vdb_media.size()) +
                     (size.vdb_media.size() == 1 ? " VDB medium (" : " VDB media (") +
                     lightmap::format_bytes(e.media_bytes) + " with the files, their trees and majorant grids)";
  }
}

void size_lightmap_vdb_media(BakeRequest& r, store::BlobStore& blobs) {
  if (!r.lightmap_memory) return;
  LightmapMemoryBasis& basis = *r.lightmap_memory;
  basis.size.vdb_media.clear();
  basis.vdb_media_fields.clear();
  for (const BlobRef& ref : r.inputs) {
    if (ref.field.find(".media[") == std::string::npos) continue;
    const volume::MediumInput& m = r.lightmap().media.at(index_in(ref.field));
    const std::string bytes = read_input(ref, blobs);
    try {
      basis.size.vdb_media.push_back(lightmap::vdb_medium_size(
          {reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()}, m.density_grid, m.emission_grid));
    } catch (const bake::InvalidInput& e) {
      throw InvalidField(ref.field, e.field() == "bytes" ? e.problem() : e.field() + ": " + e.problem());
    }
    basis.vdb_media_fields.push_back(ref.field);
  }
  plan_lightmap_memory(r, r.lightmap().memory_limit_bytes);
}

namespace {

// The baker's own validation is the backstop, and knows the effects its planner decides.
void validate_lightmap(const lightmap::LightmapBakeInput& in) {
  if (auto problem = lightmap::validate(in)) {
    const std::string& field = problem->field();
    if (field.rfind("force_effects", 0) == 0) throw baker_problem("job", *problem);
    if (field == "max_samples" || field == "min_samples" || field == "target_error" || field == "time_limit_seconds") {
      throw baker_problem("job.quality", *problem);
    }
    throw baker_problem(kPath, *problem);
  }
}

// The scene part, serialized deterministically, for the cache key: settings go to the canonical text instead
// (with their defaults applied), so that they are cleared here.
std::string scene_hash(const kiln::v1::LightmapJob& j) {
  kiln::v1::LightmapJob scene_part = j;
  scene_part.clear_resolution();
  scene_part.clear_lightmaps();
  scene_part.clear_padding();
  scene_part.clear_max_bounces();
  scene_part.clear_radiance();
  scene_part.clear_ao();
  scene_part.clear_directional();
  scene_part.clear_preview();
  scene_part.clear_denoise();
  scene_part.clear_stitch_seams();
  scene_part.clear_error_metric();
  scene_part.clear_generate_uvs();
  scene_part.clear_texel_density();
  scene_part.clear_page_size();
  scene_part.clear_max_pages();
  scene_part.clear_uniform_pages();
  scene_part.clear_probes();
  std::string bytes;
  {
    google::protobuf::io::StringOutputStream stream(&bytes);
    google::protobuf::io::CodedOutputStream coded(&stream);
    coded.SetSerializationDeterministic(true);
    scene_part.SerializeToCodedStream(&coded);
  }
  return proto::sha256_hex(bytes);
}

}  // namespace

void translate_lightmap(const kiln::v1::JobSpec& spec, const store::BlobStore* blobs, BakeRequest& r) {
  const kiln::v1::LightmapJob& j = spec.lightmap();
  lightmap::LightmapBakeInput& in = r.input.emplace<lightmap::LightmapBakeInput>();
  scene::Scene& sc = in.scene;
  check_counts(j);
  meshes(j, blobs, r, sc);
  textures(j, blobs, r, in);
  material_overrides(j, materials(j, sc), sc);
  const std::set<std::string> lightmap_names = instances(j, sc);
  lights(j, sc);
  if (j.has_environment()) environment(j.environment(), kPath + ".environment", blobs, r);
  media(j, blobs, r);
  atlas_settings(j, in);
  resolutions(j, lightmap_names, in);
  check_texels(lightmap_names, in);
  bake_settings(j, in);
  if (j.has_probes()) probe_volume(j.probes(), kPath + ".probes", in.probes);
  lightmap_quality(spec.quality(), in);
  in.force_effects = forced_effects(spec);
  check_total_input(r);
  validate_lightmap(in);
  r.scene_hash = scene_hash(j);
  estimate_memory(j, lightmap_names, r);
}

void load_lightmap_inputs(BakeRequest& r, store::BlobStore& blobs) {
  lightmap::LightmapBakeInput& in = r.lightmap();
  for (const BlobRef& ref : r.inputs) {
    std::string bytes = read_input(ref, blobs);
    if (ref.field.find(".meshes[") != std::string::npos) {
      const std::size_t i = index_in(ref.field);
      in.scene.meshes.at(i) = decode_mesh_blob(bytes, ref.field, in.scene.meshes.at(i).name);
    } else if (ref.field.find(".textures[") != std::string::npos) {
      in.textures.at(index_in(ref.field)).bytes = std::move(bytes);
    } else if (ref.field.find(".media[") != std::string::npos) {
      load_vdb_grids(ref, bytes, in.media.at(index_in(ref.field)));
    } else {
      in.environment_image = std::move(bytes);
    }
  }
}

std::string lightmap_canonical_text(const BakeRequest& r) {
  const lightmap::LightmapBakeInput& in = r.lightmap();
  std::ostringstream o;
  o << "type=" << job_type(r) << "\nscene=" << r.scene_hash << "\nblobs=";
  for (const BlobRef& b : r.inputs) o << b.field << ":" << b.sha256 << "/" << b.size << ";";
  const envmap::EnvDecodeOptions& d = in.environment_decode;
  o << "\nenvironment_color_space=" << (d.color_space.empty() ? "(format default)" : d.color_space)
    << "\nenvironment_rotation_degrees=" << format_number(d.rotation_degrees)
    << "\nenvironment_intensity=" << format_number(d.intensity) << "\nresolution=" << in.resolution << "\nresolutions=";
  for (const auto& [name, n] : in.resolutions) o << name.size() << ":" << name << "=" << n << ";";
  o << "\npadding=" << in.padding << "\ntarget_error=" << format_number(in.target_error)
    << "\nmin_samples=" << in.min_samples << "\nmax_samples=" << in.max_samples
    << "\ntime_limit_seconds=" << format_number(in.time_limit_seconds) << "\nseed=" << in.seed
    << "\nmax_bounces=" << in.max_bounces << "\nforce_effects=";
  for (const auto& [effect, on] : in.force_effects) o << effect << (on ? "+" : "-") << ";";
  o << "\nradiance=" << in.radiance << "\nao=" << in.ao << "\ndirectional=" << in.directional
    << "\npreview=" << in.preview << "\ndenoise=" << in.denoise << "\nstitch_seams=" << in.stitch_seams
    << "\nerror_metric=" << lightmap::to_string(in.error_metric)
    << "\ngenerate_uvs=" << uvgen::to_string(in.generate_uvs) << "\n";
  // Tiles change the bytes (not the answer beyond the noise): a tiled bake is another result. Untiled bakes keep the
  // key they had before tiles existed.
  if (in.tile_size > 0) o << "tile_size=" << in.tile_size << "\n";
  // Only when packing, so that the keys of jobs without atlas pages stay what they were. The per-instance options
  // are in the scene part.
  if (in.atlas.texel_density > 0) {
    o << "texel_density=" << format_number(in.atlas.texel_density) << "\npage_size=" << in.atlas.page_size
      << "\nmax_pages=" << in.atlas.max_pages << "\n";
    if (in.atlas.uniform_pages) o << "uniform_pages=1\n";
  }
  // Only with probes, so that the keys of jobs without them stay what they were (a probes job's type differs).
  if (in.probes.enabled()) o << probes_canonical_text(in.probes);
  return o.str();
}

}  // namespace kiln::daemon::detail
