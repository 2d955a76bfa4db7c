// The scene a lightmap bake reads: meshes with their lightmap UVs, instances of them, materials, textures, lights and
// an environment. Plain data, in the working colour space and in scene units (metres by convention; nothing depends
// on the unit: ray offsets scale with the scene, see tracer.h). The daemon translates job messages into this; the
// client's importers fill the job messages from glTF, OBJ and FBX.
//
// Conventions: +Y up, right-handed; radiance in W·m⁻²·sr⁻¹ per RGB channel, irradiance in W·m⁻²;
// triangles are counter-clockwise seen from their front (the side the geometric normal (p1 − p0) × (p2 − p0) points
// to).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "bakers/brdf/material.h"
#include "bakers/math/rgb.h"
#include "bakers/math/sampling.h"
#include "bakers/math/vec3.h"

namespace kiln::scene {

// A row-major 3×4 affine transform: p' = M p + t (the last column is t).
struct Transform {
  std::array<double, 12> m{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
  Vec3 point(const Vec3& p) const {
    return {m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3], m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7],
            m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11]};
  }
  Vec3 vector(const Vec3& v) const {
    return {m[0] * v.x + m[1] * v.y + m[2] * v.z, m[4] * v.x + m[5] * v.y + m[6] * v.z,
            m[8] * v.x + m[9] * v.y + m[10] * v.z};
  }
};

struct Mesh {
  std::string name;
  std::vector<Vec3> positions;
  std::vector<Vec3> normals;        // per vertex; empty: the geometric normal of each triangle
  std::vector<Point2> uv;           // texture UVs (set 0); empty if the mesh has none
  std::vector<Point2> lightmap_uv;  // lightmap UVs (set 1, else set 0); empty: the mesh gets no lightmap
  std::vector<uint32_t> indices;    // three per triangle, into positions (and the per-vertex arrays)
  std::vector<uint32_t> material;   // per triangle, into Scene::materials; empty: material 0 for every triangle
};

// An RGB texture in the working space (base colour textures are converted from sRGB on import), sampled bilinearly
// with wrap-around addressing; v = 0 is the top row (glTF's convention).
struct Texture {
  std::string name;
  int width = 0, height = 0;
  std::vector<Rgb> texels;  // row-major, width × height
};

struct SceneMaterial {
  std::string name;
  brdf::MaterialSpec bsdf;                // diffuse + specular lobes of the BRDF library
  Rgb base_color{1, 1, 1};                // multiplies the diffuse lobe (and base_color_texture, if any)
  std::optional<int> base_color_texture;  // into Scene::textures, sampled at the mesh's `uv`
  Rgb emission{0, 0, 0};                  // emitted radiance L_e (front side only unless two_sided); > 0: an area light
  bool two_sided = false;
};

// What a scene's light is, as described; the light sampler builds its LightSources from these (lights.h's
// LightSamplerKind: a directional light with an angular diameter becomes a sun).
enum class LightShape { point, spot, directional, rect, disk };

struct Light {
  LightShape type = LightShape::point;
  std::string name;
  Rgb color{1, 1, 1};  // point/spot: intensity I (W·sr⁻¹); directional: irradiance E at normal incidence (W·m⁻²);
                       // rect/disk: emitted radiance L_e (W·m⁻²·sr⁻¹), from the front side (along `direction`)
  Vec3 position;                // point, spot, rect and disk (the centre)
  Vec3 direction{0, -1, 0};     // spot: the cone axis; directional: the direction light travels; rect/disk: the normal
  double angular_diameter = 0;  // directional: the sun's disc, radians (0: a delta direction), [0, π/2)
  double inner_cone = 0, outer_cone = 0.7853981633974483;  // spot: radians, smooth falloff between (glTF)
  Vec3 u_axis{1, 0, 0};                                    // rect: edge vector along width (full length); disk: unused
  Vec3 v_axis{0, 0, 1};                                    // rect: edge vector along height (full length)
  double radius = 0;                                       // disk radius; point/spot: 0 (a delta light)
  bool two_sided = false;                                  // rect/disk
};

struct Environment {
  // Exactly one of: a constant radiance, or an equirectangular image (working space, intensity applied) with a
  // rotation about +Y (the convention of bakers/envmap/env_input.h).
  std::optional<Rgb> constant;
  int width = 0, height = 0;
  std::vector<Rgb> equirect;  // row-major; empty with no constant: no environment (black)
  double rotation_degrees = 0;
  bool present() const { return constant.has_value() || !equirect.empty(); }
};

struct Instance {
  int mesh = 0;      // into Scene::meshes
  std::string name;  // for people and lightmaps.json (a node's name); may be empty, need not be unique
  Transform to_world;
  std::string lightmap;  // the lightmap it bakes into: empty = "<mesh name>"; instances may share an atlas
  // Where this instance's lightmap UVs land in its lightmap: uv' = (s_u·u + o_u, s_v·v + o_v), as
  // {s_u, s_v, o_u, o_v} (Unity's lightmapScaleOffset). Instances sharing an atlas (or several instances of one mesh
  // baking into the same lightmap) need disjoint rectangles, else their texels overlap (scene_check reports it).
  std::array<double, 4> lightmap_scale_offset{1, 1, 0, 0};
  bool bake = true;  // false: it casts shadows and bounces light but gets no lightmap
};

struct Scene {
  std::vector<Mesh> meshes;
  std::vector<Instance> instances;
  std::vector<SceneMaterial> materials;  // at least one: meshes without materials use materials[0]
  std::vector<Texture> textures;
  std::vector<Light> lights;
  Environment environment;
};

}  // namespace kiln::scene
