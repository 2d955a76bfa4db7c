// Scene import: glTF 2.0, OBJ and FBX (anything Assimp reads) into a lightmap job's scene, with the blobs it refers
// to. The daemon validates everything again; the importer's job is to carry over what the file says, faithfully,
// and to say what it could not.
//
// Mapping
// - Meshes: triangles only (points and lines dropped, with a warning), TEXCOORD_0 as texture UVs, TEXCOORD_1 (else
//   TEXCOORD_0) as lightmap UVs, normals if present. Assimp splits a mesh by material into pieces that one node
//   places (and renames: glTF's NAME-0, NAME-1, ..., OBJ's after their material); the pieces share one lightmap,
//   so one UV atlas, named after the mesh of the file they come from.
// - Instances: one per node that refers to a mesh, with the node's accumulated transform. A mesh used by several
//   nodes gets one lightmap per node, named MESH@NODE (made unique with #1, #2, ...), since its placements would
//   overlap in a shared atlas. (kilnd turns any lightmap name into a safe file name for the outputs and lists the
//   mapping in report.json.)
// - Materials (glTF metallic-roughness): a GGX lobe of α = roughness² (roughness at least 0.03) with Schlick's
//   Fresnel, f0 = lerp(0.04, base colour factor, metallic), layered over a Lambertian lobe of albedo (1 − metallic)
//   that base_color (the factor, and its texture) multiplies: glTF's c_diff. The texture tints the diffuse lobe only;
//   metallicRoughness, normal, occlusion, emissive and specular textures are not read (a warning names the
//   materials), nor are glTF extensions other than KHR_lights_punctual, KHR_materials_emissive_strength,
//   KHR_materials_specular, KHR_materials_ior and KHR_mesh_quantization (a warning each). Other formats: diffuse colour as the base colour;
//   a specular colour with shininess Ns becomes that GGX lobe with f0 = Ks and α = √(2/(Ns + 2)) (the Phong–Beckmann
//   equivalence); without a specular colour or shininess, no specular lobe. glTF's KHR_materials_specular and
//   KHR_materials_ior set the dielectric's f0 = min(((ior − 1)/(ior + 1))² · specularColorFactor, 1) ·
//   specularFactor before the metallic blend; an f0 of 0 (specularFactor or specularColorFactor 0 on a dielectric)
//   leaves the material without a specular lobe. (The extension weights the whole Fresnel term by specularFactor;
//   kiln's Schlick term with the scaled f0 still rises to 1 at grazing: the two agree at normal incidence and at 0.)
//   Emission: the emissive colour times KHR_materials_emissive_strength (read from the glTF's JSON by
//   material index: Assimp 5.2 ignores it); the emissive texture is not read. doubleSided → two_sided.
// - Textures: base-colour textures uploaded as they are (the file's bytes), declared srgb_texture; one Texture per
//   image however many materials use it. External files are looked for beside the model (glTF URIs percent-decoded;
//   failing that, the bare file name beside the model); embedded ones (data URIs, GLB or bufferView images) are
//   taken from Assimp. An image that cannot be read is a warning, and the material keeps its base colour alone.
// - Lights (KHR_lights_punctual, which Assimp 5.2 reads, and the other formats' lights): point, spot and
//   directional, placed by the node of the light's name (position and direction in world space; glTF lights shine
//   along the node's −Z). Spot cone angles are kiln's half-angles from the axis (glTF's as they are; other formats'
//   apex angles halved). Directional lights get the daemon's default sun disc. Units: Assimp gives colour ×
//   intensity, which carries over unchanged (glTF's candela as kiln's W/sr for point and spot, lux as W/m² of
//   irradiance for directional, as emissive strengths carry cd/m² over as W/m²/sr: one factor for every emitter,
//   so their proportions hold). glTF's `range` is ignored, with a warning (kiln's lights fall off as 1/r²).
#pragma once

#include <map>
#include <string>
#include <vector>

#include "proto/kiln.pb.h"

namespace kiln::client {

struct ImportedScene {
  v1::LightmapJob job;                       // meshes, instances, materials, textures, lights; digests filled
  std::map<std::string, std::string> blobs;  // SHA-256 hex → bytes, to upload before submitting
  std::vector<std::string> warnings;         // for people: what was dropped or approximated, and why
};

// Throws std::runtime_error with a message for people if the file cannot be read or holds no triangles.
ImportedScene import_scene(const std::string& path);

}  // namespace kiln::client
