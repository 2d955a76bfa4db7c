#include "client/import/scene_import.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>

#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <assimp/Importer.hpp>
#include <boost/property_tree/json_parser.hpp>
#include <boost/property_tree/ptree.hpp>

#include "client/import/mesh_blob.h"
#include "proto/digest.h"
#include "proto/text.h"

namespace kiln::client {
namespace {

// A factor in [0, 1]; 0 for NaN.
double clamp01(double v) { return std::isfinite(v) ? std::clamp(v, 0.0, 1.0) : 0.0; }

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path + ": " + std::strerror(errno));
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Binary glTF (GLB, by its magic, whatever the file's name): a 12-byte header, then chunks of an 8-byte header (length,
// type) and `length` bytes. Assimp allocates each chunk's length as its header gives it before reading, so a damaged
// header of a few hundred bytes can ask for 4 GB: a chunk that claims more than the file holds after it is refused.
struct GlbChunk {
  char type[4];
  uint64_t offset;  // of its data
  uint32_t length;
};

// The chunks of `path`, or none if it is not GLB (or cannot be read: Assimp reports that). Throws for a chunk longer
// than what follows its header.
std::vector<GlbChunk> glb_chunks(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) return {};
  const auto size = static_cast<uint64_t>(in.tellg());
  char header[12];
  in.seekg(0);
  if (size < sizeof header || !in.read(header, sizeof header) || std::memcmp(header, "glTF", 4) != 0) return {};
  std::vector<GlbChunk> chunks;
  uint64_t offset = sizeof header;
  while (offset + 8 <= size) {
    GlbChunk chunk{};
    in.seekg(static_cast<std::streamoff>(offset));
    if (!in.read(reinterpret_cast<char*>(&chunk.length), sizeof chunk.length) || !in.read(chunk.type, 4)) break;
    if (chunk.length > size - offset - 8) {
      throw std::runtime_error("cannot import " + path + ": its GLB chunk " + std::to_string(chunks.size()) +
                               " says it holds " + std::to_string(chunk.length) + " bytes, but only " +
                               std::to_string(size - offset - 8) +
                               " follow its header; the file is truncated or damaged: export it again");
    }
    chunk.offset = offset + 8;
    chunks.push_back(chunk);
    offset = chunk.offset + chunk.length;
  }
  return chunks;
}

// A GLB's JSON (its first chunk, by the format) from its `chunks` (glb_chunks), or "" if it has none.
std::string glb_json(const std::string& path, const std::vector<GlbChunk>& chunks) {
  if (chunks.empty() || std::memcmp(chunks[0].type, "JSON", 4) != 0) return "";
  std::ifstream in(path, std::ios::binary);
  std::string json(chunks[0].length, '\0');
  in.seekg(static_cast<std::streamoff>(chunks[0].offset));
  if (!in.read(json.data(), static_cast<std::streamsize>(json.size()))) return "";
  return json;
}

std::string directory_of(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? std::string(".") : path.substr(0, slash);
}

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && std::equal(tail.rbegin(), tail.rend(), s.rbegin(),
                                               [](char a, char b) { return std::tolower(a) == std::tolower(b); });
}

// KHR_materials_specular and KHR_materials_ior of one glTF material, with the extensions' defaults.
struct GltfSpecular {
  double factor = 1;              // specularFactor
  double color[3] = {1, 1, 1};    // specularColorFactor
  double ior = 1.5;               // KHR_materials_ior
  std::vector<std::string> unread_textures;  // the material's textures kiln does not read ("normalTexture", ...)
};

// What the glTF's JSON says that Assimp 5.2 does not pass on: KHR_materials_emissive_strength,
// KHR_materials_specular, KHR_materials_ior, the lights' `range`, and which extensions and textures the file uses.
// By index: Assimp keeps glTF's material and light order (it appends its default material last), while names need
// be neither present nor unique.
struct GltfExtras {
  std::map<unsigned, double> emissive_strength;  // material index → emissiveStrength
  std::map<unsigned, GltfSpecular> specular;     // material index → its specular and ior extensions, textures
  std::map<unsigned, double> light_range;        // KHR_lights_punctual light index → range
  std::vector<std::string> extensions_used;      // the file's extensionsUsed
};

// The textures of a glTF material that kiln's lightmap materials have no use for (the base colour's is read).
std::vector<std::string> unread_textures(const boost::property_tree::ptree& material) {
  static const char* const kPaths[] = {"normalTexture",
                                       "occlusionTexture",
                                       "emissiveTexture",
                                       "pbrMetallicRoughness.metallicRoughnessTexture",
                                       "extensions.KHR_materials_specular.specularTexture",
                                       "extensions.KHR_materials_specular.specularColorTexture"};
  std::vector<std::string> out;
  for (const char* path : kPaths) {
    if (material.get_child_optional(path)) out.push_back(path);
  }
  return out;
}

GltfSpecular gltf_specular(const boost::property_tree::ptree& material) {
  GltfSpecular s;
  s.factor = material.get("extensions.KHR_materials_specular.specularFactor", 1.0);
  if (const auto color = material.get_child_optional("extensions.KHR_materials_specular.specularColorFactor")) {
    int c = 0;
    for (const auto& [key, v] : *color) {
      if (c < 3) s.color[c++] = v.get_value<double>();
    }
  }
  s.ior = material.get("extensions.KHR_materials_ior.ior", 1.5);
  s.unread_textures = unread_textures(material);
  return s;
}

GltfExtras gltf_extras(const std::string& path, const std::vector<GlbChunk>& chunks) {
  GltfExtras out;
  std::string json;
  if (ends_with(path, ".gltf")) {
    json = read_file(path);
  } else if (ends_with(path, ".glb")) {
    json = glb_json(path, chunks);
    if (json.empty()) return out;
  } else {
    return out;
  }
  try {
    boost::property_tree::ptree tree;
    std::istringstream in(json);
    boost::property_tree::read_json(in, tree);
    unsigned i = 0;
    if (const auto materials = tree.get_child_optional("materials")) {
      for (const auto& [key, material] : *materials) {
        const auto strength =
            material.get_optional<double>("extensions.KHR_materials_emissive_strength.emissiveStrength");
        if (strength) out.emissive_strength[i] = *strength;
        out.specular[i] = gltf_specular(material);
        ++i;
      }
    }
    if (const auto used = tree.get_child_optional("extensionsUsed")) {
      for (const auto& [key, name] : *used) out.extensions_used.push_back(name.get_value<std::string>());
    }
    i = 0;
    if (const auto lights = tree.get_child_optional("extensions.KHR_lights_punctual.lights")) {
      for (const auto& [key, light] : *lights) {
        if (const auto range = light.get_optional<double>("range")) out.light_range[i] = *range;
        ++i;
      }
    }
  } catch (const std::exception&) {
    // Malformed JSON: Assimp has read the file already or will say what is wrong with it.
  }
  return out;
}

// glTF image URIs are RFC 3986 references ("my%20wood.png" is the file "my wood.png"); Assimp 5.2 passes them on
// undecoded. A malformed escape is kept as it is.
std::string percent_decoded(const std::string& uri) {
  std::string out;
  for (size_t i = 0; i < uri.size(); ++i) {
    if (uri[i] == '%' && i + 2 < uri.size() && std::isxdigit(static_cast<unsigned char>(uri[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(uri[i + 2]))) {
      out += static_cast<char>(std::stoi(uri.substr(i + 1, 2), nullptr, 16));
      i += 2;
    } else {
      out += uri[i];
    }
  }
  return out;
}

// A name from the file as a protocol string: UTF-8 (protobuf refuses a frame with anything else in a string field,
// and files carry names in other encodings: Latin-1 material names in OBJ files), each byte that is not replaced by
// U+FFFD, cut to `max_bytes` without cutting a character. The original bytes stay where they matter: texture files
// are looked for by them.
std::string wire_name(const std::string& name, size_t max_bytes = 256) {
  return proto::utf8_prefix(proto::to_utf8(name), max_bytes);
}

// `name` as a protocol string (wire_name) if `used` does not hold it yet, else name#1, name#2, ...: kiln wants mesh,
// material and light names unique, which files do not promise (nor do names made UTF-8).
std::string unique_name(std::set<std::string>& used, const std::string& name) {
  const std::string valid = proto::to_utf8(name);
  std::string out = proto::utf8_prefix(valid, 256);
  for (int n = 1; !used.insert(out).second; ++n) out = proto::utf8_prefix(valid, 240) + "#" + std::to_string(n);
  return out;
}

v1::Color color(double r, double g, double b) {
  v1::Color c;
  c.set_r(r);
  c.set_g(g);
  c.set_b(b);
  return c;
}

v1::Vector3 vec(const aiVector3D& v) {
  v1::Vector3 out;
  out.set_x(v.x);
  out.set_y(v.y);
  out.set_z(v.z);
  return out;
}

class Importer {
 public:
  explicit Importer(const std::string& path)
      : path_(path), gltf_(ends_with(path, ".gltf") || ends_with(path, ".glb")) {}

  ImportedScene run() {
    Assimp::Importer importer;
    // FlipUVs: Assimp turns every format's UVs to v = 0 at the bottom; kiln keeps glTF's v = 0 at the top.
    const unsigned flags = aiProcess_Triangulate | aiProcess_SortByPType | aiProcess_JoinIdenticalVertices |
                           aiProcess_FlipUVs | aiProcess_ValidateDataStructure;
    // Throws for a chunk longer than the file, before Assimp allocates it; the glTF extras read its JSON chunk.
    const std::vector<GlbChunk> chunks = glb_chunks(path_);
    scene_ = importer.ReadFile(path_, flags);
    if (!scene_ || !scene_->mRootNode) {
      throw std::runtime_error("cannot import " + path_ + ": " + importer.GetErrorString());
    }
    extras_ = gltf_extras(path_, chunks);
    materials();
    meshes();
    count_node_uses(scene_->mRootNode);
    instances(scene_->mRootNode, aiMatrix4x4());
    lights();
    if (out_.job.instances_size() == 0) {
      throw std::runtime_error("cannot import " + path_ + ": it has no triangle meshes");
    }
    return std::move(out_);
  }

 private:
  std::string add_blob(std::string bytes, v1::Digest* digest) {
    const std::string sha = proto::sha256_hex(bytes);
    digest->set_sha256(sha);
    digest->set_size(bytes.size());
    out_.blobs.emplace(sha, std::move(bytes));
    return sha;
  }

  // Where an external image may be, most literal first: the name relative to the model's folder (percent-decoded
  // for glTF, whose image URIs are URI references); with Windows separators turned; the bare file name beside the
  // model (exporters often write the absolute path of the machine they ran on).
  std::vector<std::string> texture_paths(const std::string& name) const {
    const std::string dir = directory_of(path_) + "/";
    std::vector<std::string> out;
    auto add = [&](const std::string& file) {
      if (file.empty()) return;
      const std::string path = file[0] == '/' ? file : dir + file;
      if (std::find(out.begin(), out.end(), path) == out.end()) out.push_back(path);
    };
    const std::string decoded = gltf_ ? percent_decoded(name) : name;
    add(decoded);
    add(name);  // a file whose name holds a literal '%'
    std::string slashes = decoded;
    std::replace(slashes.begin(), slashes.end(), '\\', '/');
    add(slashes);
    add(slashes.substr(slashes.find_last_of('/') + 1));  // npos + 1 = 0: the whole name
    return out;
  }

  std::optional<uint32_t> texture(const aiMaterial* m) {
    aiString file;
    if (m->GetTexture(aiTextureType_BASE_COLOR, 0, &file) != AI_SUCCESS &&
        m->GetTexture(aiTextureType_DIFFUSE, 0, &file) != AI_SUCCESS) {
      return std::nullopt;
    }
    const std::string name = file.C_Str();
    if (auto it = textures_.find(name); it != textures_.end()) return it->second;
    std::string bytes;
    if (const aiTexture* embedded = scene_->GetEmbeddedTexture(file.C_Str())) {
      if (embedded->mHeight != 0) {  // raw texels, not an encoded file: rare, and not worth a second path
        out_.warnings.push_back("texture " + name + ": embedded as raw texels, not supported; ignored");
        return std::nullopt;
      }
      bytes.assign(reinterpret_cast<const char*>(embedded->pcData), embedded->mWidth);
    } else {
      std::string error;
      for (const std::string& candidate : texture_paths(name)) {
        try {
          bytes = read_file(candidate);
          error.clear();
          break;
        } catch (const std::exception& e) {
          if (error.empty()) error = e.what();  // the first, most literal reading of the name
        }
      }
      if (!error.empty()) {
        out_.warnings.push_back("texture " + name + ": " + error + "; the material uses its base colour alone");
        return std::nullopt;
      }
    }
    v1::Texture* t = out_.job.add_textures();
    t->set_name(wire_name(name));
    t->set_color_space("srgb_texture");
    add_blob(std::move(bytes), t->mutable_image());
    const uint32_t index = static_cast<uint32_t>(out_.job.textures_size() - 1);
    textures_[name] = index;
    return index;
  }

  void materials() {
    std::set<std::string> material_names;
    for (unsigned i = 0; i < scene_->mNumMaterials; ++i) material(i, material_names);
    if (gltf_) report_unread_gltf();
  }

  // The glTF extensions and material textures whose content the job leaves out, one warning each.
  void report_unread_gltf() {
    static const std::set<std::string> kRead = {"KHR_lights_punctual", "KHR_materials_emissive_strength",
                                                "KHR_materials_specular", "KHR_materials_ior",
                                                "KHR_mesh_quantization"};
    for (const std::string& e : extras_.extensions_used) {
      if (!kRead.count(e)) {
        out_.warnings.push_back("glTF extension " + e + ": not read by kiln's importer; what it adds is dropped");
      }
    }
    for (const auto& [texture, materials] : unread_textures_) {
      std::string names;
      for (size_t k = 0; k < materials.size() && k < 3; ++k) names += (k ? ", " : "") + materials[k];
      if (materials.size() > 3) names += " and " + std::to_string(materials.size() - 3) + " more";
      out_.warnings.push_back(texture + " of material" + (materials.size() > 1 ? "s " : " ") + names +
                              ": not read (a lightmap material takes its base colour texture only); dropped");
    }
  }

  // Material i: its name, base colour and texture, a GGX-over-Lambert BSDF, its emission and sidedness.
  void material(unsigned i, std::set<std::string>& material_names) {
    const aiMaterial* m = scene_->mMaterials[i];
    v1::SceneMaterial* out = out_.job.add_materials();
    std::string name = m->GetName().C_Str();
    if (name.empty()) name = "material_" + std::to_string(i);
    out->set_name(unique_name(material_names, name));

    aiColor4D base(1, 1, 1, 1);
    float metallic = 0, roughness = 1;
    aiColor3D specular(0, 0, 0);
    float shininess = 0;
    if (gltf_) {
      m->Get(AI_MATKEY_BASE_COLOR, base);
      m->Get(AI_MATKEY_METALLIC_FACTOR, metallic);
      m->Get(AI_MATKEY_ROUGHNESS_FACTOR, roughness);
    } else {
      aiColor3D diffuse(0.8f, 0.8f, 0.8f);
      m->Get(AI_MATKEY_COLOR_DIFFUSE, diffuse);
      base = aiColor4D(diffuse.r, diffuse.g, diffuse.b, 1);
      m->Get(AI_MATKEY_COLOR_SPECULAR, specular);
      m->Get(AI_MATKEY_SHININESS, shininess);
    }
    const double r = clamp01(base.r), g = clamp01(base.g), b = clamp01(base.b);
    *out->mutable_base_color() = color(r, g, b);
    if (auto t = texture(m)) out->set_base_color_texture(*t);
    if (gltf_) {
      set_gltf_bsdf({r, g, b}, metallic, roughness, gltf_specular_of(i, out->name()), out->mutable_bsdf());
    } else {
      set_phong_bsdf(specular, shininess, out->mutable_bsdf());
    }

    aiColor3D emissive(0, 0, 0);
    m->Get(AI_MATKEY_COLOR_EMISSIVE, emissive);
    double strength = 1;
    if (auto it = extras_.emissive_strength.find(i); gltf_ && it != extras_.emissive_strength.end()) {
      strength = it->second;
    }
    if (std::max({emissive.r, emissive.g, emissive.b}) > 0) {
      *out->mutable_emission() = color(emissive.r * strength, emissive.g * strength, emissive.b * strength);
    }
    int two_sided = 0;
    if (m->Get(AI_MATKEY_TWOSIDED, two_sided) == AI_SUCCESS) out->set_two_sided(two_sided != 0);
  }

  // Material i's specular extensions (defaults if it has none), with a warning for what of them kiln cannot use.
  GltfSpecular gltf_specular_of(unsigned i, const std::string& name) {
    GltfSpecular s;
    if (auto it = extras_.specular.find(i); it != extras_.specular.end()) s = it->second;
    if (!(std::isfinite(s.ior) && s.ior >= 0)) {
      out_.warnings.push_back("material " + name + ": KHR_materials_ior ior " + std::to_string(s.ior) +
                              " is not a number >= 0; the default 1.5 used");
      s.ior = 1.5;
    }
    for (const std::string& t : s.unread_textures) unread_textures_[t].push_back(name);
    return s;
  }

  // GGX over Lambert from glTF's metallic-roughness, with KHR_materials_specular and KHR_materials_ior.
  static void set_gltf_bsdf(const std::array<double, 3>& base, float metallic, float roughness,
                            const GltfSpecular& spec, v1::Layered* bsdf) {
    bsdf->set_combine(v1::COMBINE_LAYERED);
    const double metal = clamp01(metallic);
    *bsdf->mutable_diffuse()->mutable_lambert()->mutable_albedo() =
        color(1 - metal, 1 - metal, 1 - metal);  // times base_color: glTF's c_diff
    // The dielectric's f0 = min(((ior − 1)/(ior + 1))² · specularColorFactor, 1) · specularFactor (4 % with no
    // extension: ior 1.5), then glTF's f0 = lerp(dielectric f0, base colour, metallic).
    const double f0_ior = std::pow((spec.ior - 1) / (spec.ior + 1), 2);
    double f0[3];
    for (int c = 0; c < 3; ++c) {
      const double dielectric = std::min(f0_ior * std::max(spec.color[c], 0.0), 1.0) * clamp01(spec.factor);
      f0[c] = dielectric + (base[c] - dielectric) * metal;
    }
    // f0 = 0 (specularFactor or specularColorFactor 0 on a dielectric): no specular lobe at all, not a lobe of
    // Schlick's grazing term alone.
    if (std::max({f0[0], f0[1], f0[2]}) <= 0) return;
    v1::Microfacet* ggx = bsdf->mutable_specular()->mutable_ggx();
    ggx->set_fresnel(v1::FRESNEL_SCHLICK);
    // α = roughness² (glTF's remapping); roughness < 0.03 is a mirror beyond the BRDF library's range.
    const double a = std::max(clamp01(roughness), 0.03);
    ggx->set_alpha(a * a);
    *ggx->mutable_f0() = color(f0[0], f0[1], f0[2]);
  }

  // Lambert with, for a specular colour Ks and shininess Ns (OBJ, FBX), a GGX lobe of f0 = Ks and α = √(2/(Ns + 2)).
  static void set_phong_bsdf(const aiColor3D& specular, float shininess, v1::Layered* bsdf) {
    bsdf->set_combine(v1::COMBINE_LAYERED);
    *bsdf->mutable_diffuse()->mutable_lambert()->mutable_albedo() = color(1, 1, 1);
    if (!(std::max({specular.r, specular.g, specular.b}) > 0 && shininess > 0)) return;  // no specular lobe
    v1::Microfacet* ggx = bsdf->mutable_specular()->mutable_ggx();
    ggx->set_fresnel(v1::FRESNEL_SCHLICK);
    ggx->set_alpha(std::clamp(std::sqrt(2.0 / (shininess + 2.0)), 0.001, 1.0));
    *ggx->mutable_f0() = color(clamp01(specular.r), clamp01(specular.g), clamp01(specular.b));
  }

  void meshes() {
    std::set<std::string> mesh_names;
    for (unsigned i = 0; i < scene_->mNumMeshes; ++i) {
      const aiMesh* m = scene_->mMeshes[i];
      mesh_index_.push_back(-1);
      if (!(m->mPrimitiveTypes & aiPrimitiveType_TRIANGLE)) {
        out_.warnings.push_back("mesh " + std::string(m->mName.C_Str()) + ": points or lines only; dropped");
        continue;
      }
      MeshArrays a;
      a.positions.reserve(m->mNumVertices);
      for (unsigned v = 0; v < m->mNumVertices; ++v) {
        a.positions.push_back({m->mVertices[v].x, m->mVertices[v].y, m->mVertices[v].z});
      }
      if (m->HasNormals()) {
        for (unsigned v = 0; v < m->mNumVertices; ++v) {
          a.normals.push_back({m->mNormals[v].x, m->mNormals[v].y, m->mNormals[v].z});
        }
      }
      auto uvs = [&](unsigned set, std::vector<std::array<float, 2>>& into) {
        for (unsigned v = 0; v < m->mNumVertices; ++v) {
          into.push_back({m->mTextureCoords[set][v].x, m->mTextureCoords[set][v].y});
        }
      };
      if (m->HasTextureCoords(0)) uvs(0, a.uv);
      if (m->HasTextureCoords(1)) {
        uvs(1, a.lightmap_uv);
      } else if (m->HasTextureCoords(0)) {
        a.lightmap_uv = a.uv;
      }
      std::string base_name = m->mName.length ? m->mName.C_Str() : "mesh_" + std::to_string(i);
      if (a.lightmap_uv.empty()) {
        out_.warnings.push_back("mesh " + base_name +
                                ": no UVs for a lightmap; kilnd generates them (unless the job's generate_uvs is "
                                "never, when it casts shadows but is not baked)");
      }
      for (unsigned f = 0; f < m->mNumFaces; ++f) {
        const aiFace& face = m->mFaces[f];
        if (face.mNumIndices != 3) continue;  // points and lines left by SortByPType in a mixed mesh
        a.indices.insert(a.indices.end(), {face.mIndices[0], face.mIndices[1], face.mIndices[2]});
      }
      a.materials.assign(a.indices.size() / 3, m->mMaterialIndex);
      v1::Mesh* out = out_.job.add_meshes();
      out->set_name(unique_name(mesh_names, base_name));
      add_blob(encode_mesh_blob(a), out->mutable_geometry());
      mesh_index_.back() = out_.job.meshes_size() - 1;
    }
  }

  std::string ai_mesh_name(unsigned ai_mesh) const {
    const aiMesh* m = scene_->mMeshes[ai_mesh];
    return m->mName.length ? m->mName.C_Str() : "mesh_" + std::to_string(ai_mesh);
  }

  // The name of the file's mesh that aiMesh `ai_mesh`, placed by `node`, is a piece of: the lightmap its pieces
  // share. Assimp splits a mesh with several materials into pieces that the mesh's node places together, named in a
  // way of its own per format: glTF's importer appends "-0", "-1", ... (the primitive's index) to the mesh's name,
  // OBJ's names each piece after the first by its material. So: a node with one mesh gives that mesh's name (nodes
  // placing meshes of one name share a lightmap: that is how a file asks for a shared atlas); pieces of one name give
  // it; pieces NAME-<n> give NAME; other pieces give the node's name (OBJ's object, FBX's model). Every piece
  // counts, triangles or not: glTF's numbering covers the points and lines too.
  std::string source_mesh_name(const aiNode* node, unsigned ai_mesh) const {
    if (node->mNumMeshes < 2) return ai_mesh_name(ai_mesh);
    std::vector<std::string> names;
    for (unsigned i = 0; i < node->mNumMeshes; ++i) names.push_back(ai_mesh_name(node->mMeshes[i]));
    if (std::all_of(names.begin(), names.end(), [&](const std::string& n) { return n == names[0]; })) {
      return names[0];
    }
    const std::string stem = piece_stem(names[0]);
    if (!stem.empty() &&
        std::all_of(names.begin(), names.end(), [&](const std::string& n) { return piece_stem(n) == stem; })) {
      return stem;
    }
    return node->mName.length ? node->mName.C_Str() : ai_mesh_name(ai_mesh);
  }

  // NAME of "NAME-<digits>" (how glTF's importer names a primitive of a mesh with several); "" for other names.
  static std::string piece_stem(const std::string& name) {
    const size_t dash = name.find_last_of('-');
    if (dash == std::string::npos || dash == 0 || dash + 1 == name.size()) return "";
    const bool digits = std::all_of(name.begin() + dash + 1, name.end(),
                                    [](char c) { return std::isdigit(static_cast<unsigned char>(c)); });
    return digits ? name.substr(0, dash) : "";
  }

  void count_node_uses(const aiNode* node) {
    for (unsigned i = 0; i < node->mNumMeshes; ++i) ++uses_[node->mMeshes[i]];
    for (unsigned c = 0; c < node->mNumChildren; ++c) count_node_uses(node->mChildren[c]);
  }

  void instances(const aiNode* node, const aiMatrix4x4& parent) {
    const aiMatrix4x4 world = parent * node->mTransformation;
    world_of_node_.emplace(node->mName.C_Str(), world);
    for (unsigned i = 0; i < node->mNumMeshes; ++i) {
      const unsigned ai_mesh = node->mMeshes[i];
      const int mesh = ai_mesh < mesh_index_.size() ? mesh_index_[ai_mesh] : -1;
      if (mesh < 0) continue;
      v1::Instance* inst = out_.job.add_instances();
      inst->set_mesh(static_cast<uint32_t>(mesh));
      // The node's name, for people: lightmaps.json and the report list each instance by it.
      if (node->mName.length) inst->set_name(wire_name(node->mName.C_Str()));
      // aiMatrix4x4 is row-major with the translation in the last column: the first three rows are kiln's 3×4.
      const float rows[12] = {world.a1, world.a2, world.a3, world.a4, world.b1, world.b2,
                              world.b3, world.b4, world.c1, world.c2, world.c3, world.c4};
      const bool identity = world.IsIdentity();
      if (!identity) {
        for (float v : rows) inst->add_transform(v);
      }
      const std::string lightmap = source_mesh_name(node, ai_mesh);
      if (uses_[ai_mesh] > 1) {
        // Shared geometry in several places: each placement needs its own texels, in a lightmap named
        // MESH@NODE (made unique: node names need not be).
        inst->set_lightmap(placement_lightmap(node, lightmap));
      } else {
        inst->set_lightmap(wire_name(lightmap));
      }
    }
    for (unsigned c = 0; c < node->mNumChildren; ++c) instances(node->mChildren[c], world);
  }

  // The lightmap of the pieces of mesh `lightmap` that `node` places, when other nodes place that mesh too.
  std::string placement_lightmap(const aiNode* node, const std::string& lightmap) {
    const auto key = std::make_pair(node, lightmap);
    if (auto it = placement_names_.find(key); it != placement_names_.end()) return it->second;
    const std::string node_name = node->mName.length ? node->mName.C_Str() : "node";
    const std::string name = unique_name(placement_lightmaps_, lightmap + "@" + node_name);
    placement_names_.emplace(key, name);
    return name;
  }

  // Assimp names a light after the node that places it: that node's world transform (identity if none does).
  aiMatrix4x4 light_placement(const std::string& name) {
    aiMatrix4x4 world;
    const auto [first, last] = world_of_node_.equal_range(name);
    if (first == last) {
      out_.warnings.push_back("light " + name +
                              ": no node of that name places it; it stays where the file's "
                              "light itself says, in world space");
    } else {
      world = first->second;
      if (std::next(first) != last) {
        out_.warnings.push_back("light " + name +
                                ": several nodes have that name; placed by the first (give the "
                                "nodes unique names to place it by the right one)");
      }
    }
    return world;
  }

  // The light's kind and geometry, in world space; a kind kiln does not have drops the light, with a warning.
  void set_light_kind(const aiLight& light, const std::string& name, const aiVector3D& position,
                      const aiVector3D& direction, v1::Light* out) {
    switch (light.mType) {
      case aiLightSource_POINT:
        *out->mutable_point()->mutable_position() = vec(position);
        break;
      case aiLightSource_SPOT: {
        v1::SpotLight* s = out->mutable_spot();
        *s->mutable_position() = vec(position);
        *s->mutable_direction() = vec(direction);
        // kiln's cone angles are measured from the axis, as glTF's innerConeAngle and outerConeAngle, which
        // Assimp 5.2 passes on unchanged. Other formats' (FBX's cone, Collada's falloff) are apex angles: halved.
        const double scale = gltf_ ? 1.0 : 0.5;
        const double outer = std::clamp(light.mAngleOuterCone * scale, 1e-3, M_PI / 2);
        s->set_outer_cone_angle(outer);
        s->set_inner_cone_angle(std::clamp(light.mAngleInnerCone * scale, 0.0, outer));
        break;
      }
      case aiLightSource_DIRECTIONAL: {
        // Left without an angular diameter: the daemon's default, the sun's disc (kiln.proto), softens its shadows.
        *out->mutable_directional()->mutable_direction() = vec(direction);
        break;
      }
      default:
        out_.warnings.push_back("light " + name + ": type " + std::to_string(static_cast<int>(light.mType)) +
                                " is not supported (point, spot and directional are); dropped");
        out_.job.mutable_lights()->RemoveLast();
        break;
    }
  }

  void lights() {
    std::set<std::string> light_names;
    for (unsigned i = 0; i < scene_->mNumLights; ++i) {
      const aiLight* l = scene_->mLights[i];
      const std::string name = l->mName.C_Str();
      const aiMatrix4x4 world = light_placement(name);
      const aiVector3D position = world * l->mPosition;
      // A direction moves with the node's linear part (not its inverse transpose: it is not a normal).
      aiVector3D direction = aiMatrix3x3(world) * l->mDirection;
      if (direction.Length() > 0) direction.Normalize();
      v1::Light* out = out_.job.add_lights();
      out->set_name(unique_name(light_names, name));
      // Assimp has multiplied the colour by the intensity already (glTF: color × intensity). kiln's lights are
      // radiometric and glTF's photometric; the number carries over unchanged (1 cd → 1 W/sr for point and spot
      // lights, 1 lx → 1 W/m² of irradiance at normal incidence for directional ones), as in the viewers glTF
      // scenes are tuned in, and the same factor as emissive materials (1 cd/m² → 1 W/m²/sr), so that lights and
      // emitters keep their proportions. A photometric conversion would divide every one by 683 lm/W.
      *out->mutable_color() = color(l->mColorDiffuse.r, l->mColorDiffuse.g, l->mColorDiffuse.b);
      if (auto it = extras_.light_range.find(i); gltf_ && it != extras_.light_range.end()) {
        std::ostringstream range;
        range << it->second;
        out_.warnings.push_back("light " + name + ": range " + range.str() +
                                " ignored; kiln's lights fall off as 1/r² without a cut-off (the range is a hint in "
                                "KHR_lights_punctual)");
      }
      set_light_kind(*l, name, position, direction, out);
    }
  }

  std::string path_;
  bool gltf_;  // glTF 2.0 (.gltf or .glb): metallic-roughness materials, URI-encoded image names
  const aiScene* scene_ = nullptr;
  ImportedScene out_;
  GltfExtras extras_;
  std::map<std::string, uint32_t> textures_;
  std::map<std::string, std::vector<std::string>> unread_textures_;  // glTF texture kind → materials that have one
  std::set<std::string> placement_lightmaps_;  // lightmap names given to placements of shared meshes
  std::map<std::pair<const aiNode*, std::string>, std::string> placement_names_;  // (node, mesh) → its lightmap
  std::vector<int> mesh_index_;                            // aiMesh → job mesh, -1 if dropped
  std::map<unsigned, int> uses_;                           // aiMesh → nodes referring to it
  std::multimap<std::string, aiMatrix4x4> world_of_node_;  // in the order the nodes are visited
};

}  // namespace

ImportedScene import_scene(const std::string& path) { return Importer(path).run(); }

}  // namespace kiln::client
