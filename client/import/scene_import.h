// Scene import: glTF 2.0, OBJ and FBX (anything Assimp reads) into a lightmap job's scene, with the blobs it refers
// to. The daemon validates everything again; the importer's job is to carry over what the file says, faithfully,
// and to say what it could not.
//
// Mapping
// - Meshes: triangles only (points and lines dropped, with a warning), TEXCOORD_0 as texture UVs, TEXCOORD_1 (else
//   TEXCOORD_0) as lightmap UVs, normals if present. Assimp splits a mesh by material; the pieces keep their
//   file's mesh name as their lightmap, so they share its UV atlas.
// - Instances: one per node that refers to a mesh, with the node's accumulated transform. A mesh used by several
//   nodes gets one lightmap per node (named after the node), since its pieces would overlap in a shared atlas.
// - Materials (glTF metallic-roughness): a GGX lobe of α = roughness² with Schlick's Fresnel, f0 = lerp(0.04,
//   base colour, metallic), layered over a Lambertian lobe of albedo (1 − metallic) tinted by the base colour (and
//   its texture). Other formats: diffuse colour as the base colour; a specular colour with shininess Ns becomes
//   that GGX lobe with f0 = Ks and α = √(2/(Ns + 2)) (the Phong–Beckmann equivalence). Emission: the emissive colour
//   times KHR_materials_emissive_strength (read from the glTF's JSON: Assimp 5.2 ignores it).
// - Textures: base-colour textures (files beside the model, or embedded) uploaded as they are, declared sRGB.
// - Lights (KHR_lights_punctual and the other formats' lights): point, spot (cone angles), directional (a sun disc
//   of the sun's angular diameter), placed by their node.
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
