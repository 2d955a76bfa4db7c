#include "bakers/lightmap/lightmap_uvgen.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>

#include <nlohmann/json.hpp>

#include "bakers/scene/lightmap_file_names.h"
#include "bakers/scene/scene_check.h"

namespace kiln::lightmap {
namespace {

using Json = nlohmann::ordered_json;

// The linear scale of a transform: the cube root of its volume scale.
double linear_scale(const scene::Transform& t) {
  const auto& m = t.m;
  const double det =
      m[0] * (m[5] * m[10] - m[6] * m[9]) - m[1] * (m[4] * m[10] - m[6] * m[8]) + m[2] * (m[4] * m[9] - m[5] * m[8]);
  return std::cbrt(std::fabs(det));
}

// The pack options of mesh `m`: nullopt when no instance bakes it.
std::optional<uvgen::PackOptions> pack_options(const scene::Scene& scene, const LightmapBakeInput& in, size_t m) {
  uvgen::PackOptions pack;
  pack.padding = std::max(2, in.padding);
  double density = std::numeric_limits<double>::infinity(), texels = density;
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    const scene::Instance& inst = scene.instances[i];
    if (!inst.bake || inst.mesh != static_cast<int>(m) || !scene::usable_transform(inst.to_world)) continue;
    if (in.atlas.texel_density > 0) {
      const auto it = in.atlas.instances.find(static_cast<uint32_t>(i));
      const double asked = it != in.atlas.instances.end() && it->second.texel_density > 0 ? it->second.texel_density
                                                                                          : in.atlas.texel_density;
      density = std::min(density, asked * linear_scale(inst.to_world));
    } else {
      const auto it = in.resolutions.find(scene::resolved_lightmap_name(scene, inst));
      const int resolution = it != in.resolutions.end() ? it->second : in.resolution;
      const auto& so = inst.lightmap_scale_offset;
      const double s = so[0] > 0 && so[1] > 0 && so[0] <= 1 && so[1] <= 1 ? std::min(so[0], so[1]) : 1.0;
      texels = std::min(texels, resolution * s);
    }
  }
  if (in.atlas.texel_density > 0) {
    if (!std::isfinite(density) || !(density > 0)) return std::nullopt;
    pack.texels_per_unit = density;
  } else {
    if (!std::isfinite(texels)) return std::nullopt;
    pack.size = std::max(pack.padding + 1, static_cast<int>(std::floor(texels)));
  }
  return pack;
}

template <class T>
void append(std::string& out, const T& v) {
  const size_t at = out.size();
  out.resize(at + sizeof(T));
  std::memcpy(out.data() + at, &v, sizeof(T));  // little-endian hosts only (x86-64, aarch64), as the layout is
}

// The kiln mesh layout (proto/kiln.proto): float positions, normals, texture and lightmap UVs, indices, materials.
std::string encode_mesh(const scene::Mesh& m) {
  const size_t nv = m.positions.size(), nt = m.indices.size() / 3;
  const bool normals = m.normals.size() == nv, uvs = m.uv.size() == nv, materials = m.material.size() == nt;
  std::string out = "KILNMSH1";
  append(out, static_cast<uint32_t>(nv));
  append(out, static_cast<uint32_t>(nt));
  append(out, static_cast<uint32_t>((normals ? 1u : 0u) | (uvs ? 2u : 0u) | 4u | (materials ? 8u : 0u)));
  for (const Vec3& p : m.positions)
    append(out, static_cast<float>(p.x)), append(out, static_cast<float>(p.y)), append(out, static_cast<float>(p.z));
  if (normals)
    for (const Vec3& n : m.normals)
      append(out, static_cast<float>(n.x)), append(out, static_cast<float>(n.y)), append(out, static_cast<float>(n.z));
  if (uvs)
    for (const Point2& q : m.uv) append(out, static_cast<float>(q.x)), append(out, static_cast<float>(q.y));
  for (const Point2& q : m.lightmap_uv) append(out, static_cast<float>(q.x)), append(out, static_cast<float>(q.y));
  for (size_t i = 0; i < 3 * nt; ++i) append(out, m.indices[i]);
  if (materials)
    for (uint32_t k : m.material) append(out, k);
  return out;
}

}  // namespace

std::vector<GeneratedMeshUvs> generate_scene_uvs(scene::Scene& scene, const LightmapBakeInput& in,
                                                 const bake::StopCheck& stop) {
  std::vector<GeneratedMeshUvs> out;
  if (in.generate_uvs == uvgen::GenerateUvs::never) return out;
  scene::LightmapFileNames files;
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    stop.check();
    const std::optional<uvgen::PackOptions> pack = pack_options(scene, in, m);
    if (!pack) continue;
    const scene::Mesh& mesh = scene.meshes[m];
    std::string reason = "always";
    if (in.generate_uvs == uvgen::GenerateUvs::automatic) {
      reason = uvgen::unusable_lightmap_uvs(mesh);
      if (reason.empty()) continue;
    }
    uvgen::UvgenOptions options;
    options.pack = *pack;
    uvgen::GeneratedUvs g = uvgen::generate_lightmap_uvs(mesh, options, stop);
    if (g.stats.charts == 0) continue;  // nothing could be charted: the scene check says why
    const int page_room = in.atlas.page_size - pack->padding;
    if (in.atlas.texel_density > 0 && g.stats.pack.size > page_room) {
      // Larger than a page: the atlas would shrink it, and its padding with it. Packed for the page instead.
      options.pack.texels_per_unit = 0;
      options.pack.size = page_room;
      g = uvgen::generate_lightmap_uvs(mesh, options, stop);
    }
    GeneratedMeshUvs e;
    e.mesh = static_cast<int>(m);
    e.name = mesh.name;
    e.reason = reason;
    e.file = files.stem(mesh.name.empty() ? "mesh" + std::to_string(m) : mesh.name) + "_uv.bin";
    e.bytes = encode_mesh(g.mesh);
    e.stats = g.stats;
    out.push_back(std::move(e));
    scene.meshes[m] = std::move(g.mesh);
  }
  return out;
}

bake::BakeOutput generated_uvs_output(GeneratedMeshUvs& generated) {
  return {generated.file, "application/x-kiln-mesh", "data", std::move(generated.bytes)};
}

std::string generated_uvs_json(uvgen::GenerateUvs mode, const std::vector<GeneratedMeshUvs>& meshes) {
  Json j;
  j["mode"] = uvgen::to_string(mode);
  j["meshes"] = Json::array();
  for (const GeneratedMeshUvs& g : meshes) {
    const uvgen::UvgenStats& s = g.stats;
    j["meshes"].push_back({{"mesh", g.mesh},
                           {"name", g.name},
                           {"reason", g.reason},
                           {"file", g.file},
                           {"charts", s.charts},
                           {"charts_lscm", s.lscm_charts},
                           {"charts_projected", s.projection_charts},
                           {"charts_single_triangle", s.single_charts},
                           {"split_rounds", s.split_rounds},
                           {"atlas_size", s.pack.size},
                           {"texels_per_unit", s.pack.texels_per_unit},
                           {"padding", s.pack.padding},
                           {"triangles", s.quality.triangles},
                           {"triangles_uncharted", s.triangles_uncharted},
                           {"utilisation", s.quality.utilisation},
                           {"l2_stretch", s.quality.l2_stretch},
                           {"mean_angle_error_degrees", s.quality.mean_angle_error_degrees},
                           {"flipped", s.quality.flipped},
                           {"overlaps", s.quality.overlaps},
                           {"vertices_added", s.vertices_added},
                           {"seconds", s.seconds}});
  }
  return j.dump();
}

}  // namespace kiln::lightmap
