// The scene importer on the project's own Cornell box (client/examples/scenes/cornell_box.py, written into a temporary
// folder), on tiny OBJ files, and on small glTF files written here by hand (JSON, a .bin buffer and PNG images):
// meshes, lightmap UVs, instances and their lightmaps, materials (the metallic-roughness mapping, the emissive
// strength Assimp 5.2 ignores), base-colour textures (files, data URIs, bufferView images, shared and missing ones, a
// path written on another machine), KHR_lights_punctual lights placed by their nodes, and the mesh blobs, which must
// decode with the daemon's decoder to the same arrays. Expected values are worked out by hand from the files' numbers.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <variant>
#include <vector>

#include "bakers/image/png.h"
#include "bakers/scene/scene_check.h"
#include "client/import/mesh_blob.h"
#include "client/import/scene_import.h"
#include "daemon/mesh_blob_decode.h"
#include "daemon/translate.h"
#include "proto/digest.h"
#include "tests/support/temp_dir.h"

namespace kiln {
namespace {

namespace fs = std::filesystem;

// The repository, from this file's path (tests/client/scene_import_test.cpp).
fs::path source_dir() { return fs::path(KILN_SOURCE_DIR); }

bool same_uvs(const std::vector<Point2>& a, const std::vector<Point2>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a[i].x != b[i].x || a[i].y != b[i].y) return false;
  }
  return true;
}

fs::path cornell_box(const fs::path& dir) {
  const fs::path out = dir / "cornell_box.gltf";
  const std::string command = "/usr/bin/python3 " + (source_dir() / "client/examples/scenes/cornell_box.py").string() +
                              " " + out.string() + " > /dev/null";
  if (std::system(command.c_str()) != 0 || !fs::exists(out)) throw std::runtime_error("failed: " + command);
  return out;
}

// The daemon's translation of an imported job: it throws unless every index is in range and every field within
// its bounds.
daemon::BakeRequest translated(const v1::LightmapJob& job) {
  v1::JobSpec spec;
  *spec.mutable_lightmap() = job;
  return daemon::translate(spec);
}

TEST(SceneImport, CornellBoxMeshesUvsInstancesAndEmission) {
  test::TempDir dir("kiln-import");
  const client::ImportedScene s = client::import_scene(cornell_box(dir.path()).string());
  const v1::LightmapJob& j = s.job;
  std::map<std::string, int> meshes;
  for (int i = 0; i < j.meshes_size(); ++i) meshes[j.meshes(i).name()] = i;
  for (const char* name :
       {"floor", "ceiling", "back_wall", "left_wall", "right_wall", "short_block", "tall_block", "light"}) {
    EXPECT_TRUE(meshes.count(name)) << name;
  }
  // Every instance bakes into its mesh's lightmap, and every mesh has lightmap UVs (TEXCOORD_1) inside [0, 1].
  ASSERT_EQ(j.instances_size(), j.meshes_size());
  for (const v1::Instance& inst : j.instances()) {
    ASSERT_LT(inst.mesh(), static_cast<uint32_t>(j.meshes_size()));
    EXPECT_EQ(inst.lightmap(), j.meshes(inst.mesh()).name());
    EXPECT_TRUE(!inst.has_bake() || inst.bake());
  }
  for (const v1::Mesh& m : j.meshes()) {
    const std::string& bytes = s.blobs.at(m.geometry().sha256());
    EXPECT_EQ(proto::sha256_hex(bytes), m.geometry().sha256());
    EXPECT_EQ(bytes.size(), m.geometry().size());
    const scene::Mesh mesh = daemon::decode_mesh_blob(bytes, "mesh", m.name());
    ASSERT_FALSE(mesh.lightmap_uv.empty()) << m.name();
    ASSERT_EQ(mesh.lightmap_uv.size(), mesh.positions.size());
    EXPECT_FALSE(mesh.normals.empty());
    for (const Point2& uv : mesh.lightmap_uv) {
      EXPECT_TRUE(uv.x >= 0 && uv.x <= 1 && uv.y >= 0 && uv.y <= 1) << m.name() << " " << uv.x << "," << uv.y;
    }
    // The lightmap UVs are TEXCOORD_1, not the per-face 0..1 TEXCOORD_0 that every face of a block repeats.
    EXPECT_FALSE(same_uvs(mesh.lightmap_uv, mesh.uv)) << m.name();
  }
  // The emissive patch: emissiveFactor (1, 0.71, 0.24) times KHR_materials_emissive_strength 17, as the script
  // writes them; the float32 round trip of the glTF's numbers keeps 7 significant digits, hence 1e-5 relative.
  const v1::SceneMaterial* light = nullptr;
  for (const v1::SceneMaterial& m : j.materials()) {
    if (m.name() == "light") light = &m;
  }
  ASSERT_NE(light, nullptr);
  EXPECT_NEAR(light->emission().r(), 17.0, 17 * 1e-5);
  EXPECT_NEAR(light->emission().g(), 17.0 * 0.71, 17 * 1e-5);
  EXPECT_NEAR(light->emission().b(), 17.0 * 0.24, 17 * 1e-5);
  for (const v1::SceneMaterial& m : j.materials()) {
    if (m.name() != "light") {
      EXPECT_FALSE(m.has_emission()) << m.name();
    }
  }
  // The whole import passes the daemon's translation (every field within its bounds).
  EXPECT_NO_THROW(translated(j));
}

// The lightmap names of the job's instances, each with how many instances bake into it.
std::map<std::string, int> lightmaps_of(const v1::LightmapJob& j) {
  std::map<std::string, int> out;
  for (const v1::Instance& inst : j.instances()) ++out[inst.lightmap()];
  return out;
}

TEST(SceneImport, PrimitivesOfOneGltfMeshShareItsLightmap) {
  // cornell_box.py --atlas: one glTF mesh `cornell_box` with a primitive per material (white, red, green, light),
  // whose TEXCOORD_1 charts tile one atlas. Assimp makes four meshes of it, cornell_box-0 to cornell_box-3.
  test::TempDir dir("kiln-import");
  const fs::path scene = dir.path() / "cornell_box_atlas.gltf";
  const std::string command = "/usr/bin/python3 " + (source_dir() / "client/examples/scenes/cornell_box.py").string() +
                              " --atlas " + scene.string() + " > /dev/null";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  const client::ImportedScene s = client::import_scene(scene.string());
  EXPECT_EQ(s.job.meshes_size(), 4);
  EXPECT_EQ(lightmaps_of(s.job), (std::map<std::string, int>{{"cornell_box", 4}}));
  const daemon::BakeRequest r = translated(s.job);
  EXPECT_EQ(r.lightmap().scene.instances.size(), 4u);
}

TEST(SceneImport, ObjObjectWithSeveralMaterialsIsOneLightmapNamedAfterTheObject) {
  // Assimp names the second piece of `thing` after its material (b); both belong to the object. A mesh alone in its
  // node keeps its name even when it looks like a piece's (wall-1).
  test::TempDir dir("kiln-import");
  {
    std::ofstream mtl(dir.path() / "two.mtl");
    mtl << "newmtl a\nKd 1 0 0\nnewmtl b\nKd 0 1 0\n";
    std::ofstream obj(dir.path() / "two.obj");
    obj << "mtllib two.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
           "o thing\nusemtl a\nf 1/1 2/2 3/3\nusemtl b\nf 1/1 3/3 4/4\n"
           "o wall-1\nusemtl a\nf 1/1 2/2 4/4\n";
  }
  const client::ImportedScene s = client::import_scene((dir.path() / "two.obj").string());
  EXPECT_EQ(s.job.meshes_size(), 3);
  EXPECT_EQ(lightmaps_of(s.job), (std::map<std::string, int>{{"thing", 2}, {"wall-1", 1}}));
}

TEST(SceneImport, ObjWithoutSecondUvSetUsesTheFirstAndInstancesMaterials) {
  test::TempDir dir("kiln-import");
  {
    std::ofstream mtl(dir.path() / "quad.mtl");
    mtl << "newmtl clay\nKd 0.5 0.25 0.125\n";
    std::ofstream obj(dir.path() / "quad.obj");
    obj << "mtllib quad.mtl\no quad\nv 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
           "vn 0 1 0\nusemtl clay\nf 1/1/1 4/4/1 3/3/1 2/2/1\n";
  }
  const client::ImportedScene s = client::import_scene((dir.path() / "quad.obj").string());
  ASSERT_EQ(s.job.meshes_size(), 1);
  const scene::Mesh mesh =
      daemon::decode_mesh_blob(s.blobs.at(s.job.meshes(0).geometry().sha256()), "mesh", s.job.meshes(0).name());
  EXPECT_EQ(mesh.indices.size(), 6u);  // the quad, triangulated
  ASSERT_EQ(mesh.lightmap_uv.size(), mesh.positions.size());
  EXPECT_TRUE(same_uvs(mesh.lightmap_uv, mesh.uv));  // no second set: the first is the lightmap's
  bool clay = false;
  for (const v1::SceneMaterial& m : s.job.materials()) {
    if (m.name() == "clay") {
      clay = true;
      EXPECT_NEAR(m.base_color().g(), 0.25, 1e-6);  // float32 from the MTL file
    }
  }
  EXPECT_TRUE(clay);
}

// A mesh with no UVs at all is imported to bake (issue 18): kilnd generates its lightmap UVs; the warning says so.
// Before, its instance was imported with bake false, and the bake refused the scene for want of lightmap UVs.
TEST(SceneImport, ObjWithoutUvsStillBakesWithGeneratedUvs) {
  test::TempDir dir("kiln-import");
  std::ofstream(dir.path() / "bare.obj") << "o bare\nv 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nf 1 4 3 2\n";
  const client::ImportedScene s = client::import_scene((dir.path() / "bare.obj").string());
  ASSERT_EQ(s.job.instances_size(), 1);
  EXPECT_TRUE(!s.job.instances(0).has_bake() || s.job.instances(0).bake());
  bool said = false;
  for (const std::string& w : s.warnings) said |= w.find("kilnd generates them") != std::string::npos;
  EXPECT_TRUE(said);
}

TEST(SceneImport, UnreadableFilesAreErrorsForPeople) {
  test::TempDir dir("kiln-import");
  try {
    client::import_scene((dir.path() / "missing.gltf").string());
    ADD_FAILURE() << "imported a missing file";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("missing.gltf"), std::string::npos) << e.what();
  }
}

// A GLB whose JSON chunk claims 4 GB in a file of a few dozen bytes (found by the scene_import fuzzer: Assimp
// allocated the claimed length before reading): refused, naming the file and the chunk.
TEST(SceneImport, GlbChunkLongerThanTheFileIsRefusedBeforeAssimpReadsIt) {
  test::TempDir dir("kiln-import");
  const std::string json = R"({"asset":{"version":"2.0"}})";
  std::string glb = "glTF";
  const auto u32 = [&glb](uint32_t v) { glb.append(reinterpret_cast<const char*>(&v), 4); };
  u32(2);
  u32(static_cast<uint32_t>(12 + 8 + json.size()));
  u32(0xF8FF026Cu);  // the chunk's length
  glb += "JSON" + json;
  for (const char* name : {"claims.glb", "claims.gltf"}) {  // by its magic, whatever its name
    const std::filesystem::path path = dir.path() / name;
    std::ofstream(path, std::ios::binary) << glb;
    try {
      client::import_scene(path.string());
      ADD_FAILURE() << "imported " << name;
    } catch (const std::runtime_error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(name), std::string::npos) << what;
      EXPECT_NE(what.find("chunk 0 says it holds 4177461868 bytes, but only 27 follow"), std::string::npos) << what;
    }
  }
}

// ---- glTF files written by hand ---------------------------------------------------------------------------------

// A glTF 2.0 scene for one test: a unit quad in the XZ plane (positions, TEXCOORD_0, indices) as mesh i for each
// material i (or one mesh without a material), with the images, materials, lights and nodes the test gives as JSON.
// Written as NAME.gltf with its buffer NAME.bin; images given as bytes go into the buffer (bufferView images).
struct GltfScene {
  std::vector<std::string> images;     // JSON objects; texture i is image i
  std::vector<std::string> materials;  // JSON objects
  std::vector<std::string> lights;     // KHR_lights_punctual light objects
  std::vector<std::string> nodes;      // JSON objects; meshes are "mesh": i
  std::vector<int> roots;              // the scene's root nodes
  std::string bin;                     // extra buffer bytes (after the quad's 104)
  std::vector<std::string> extra_views;
  std::string extensions_used = R"(["KHR_lights_punctual", "KHR_materials_emissive_strength"])";

  // An image stored in the buffer: its bufferView's index, for {"bufferView": i, "mimeType": "image/png"}.
  int add_buffer_image(const std::string& bytes) {
    const size_t offset = 104 + bin.size();
    bin += bytes;
    while (bin.size() % 4) bin += '\0';  // the next view stays aligned
    extra_views.push_back("{\"buffer\": 0, \"byteOffset\": " + std::to_string(offset) +
                          ", \"byteLength\": " + std::to_string(bytes.size()) + "}");
    return 3 + static_cast<int>(extra_views.size()) - 1;
  }

  // A root node for each material's quad, side by side along +X.
  void place_each_mesh() {
    for (size_t i = 0; i < materials.size(); ++i) {
      roots.push_back(static_cast<int>(nodes.size()));
      nodes.push_back("{\"name\": \"n" + std::to_string(i) + "\", \"mesh\": " + std::to_string(i) +
                      ", \"translation\": [" + std::to_string(2 * i) + ", 0, 0]}");
    }
  }

  // The quad's positions, UVs and indices (104 bytes), then `bin`.
  std::string buffer() const {
    const float positions[12] = {0, 0, 0, 1, 0, 0, 1, 0, -1, 0, 0, -1};  // counter-clockwise seen from +Y
    const float uvs[8] = {0, 0, 1, 0, 1, 1, 0, 1};
    const uint32_t indices[6] = {0, 1, 2, 0, 2, 3};
    std::string out(104, '\0');
    std::memcpy(out.data(), positions, 48);
    std::memcpy(out.data() + 48, uvs, 32);
    std::memcpy(out.data() + 80, indices, 24);
    return out + bin;
  }

  // The glTF JSON, its buffer at `buffer_uri` (none: a GLB's own binary chunk).
  std::string json(const std::string& buffer_uri, size_t buffer_size) const {
    auto list = [](const std::vector<std::string>& items) {
      std::string out;
      for (const std::string& item : items) out += (out.empty() ? "" : ", ") + item;
      return "[" + out + "]";
    };
    std::vector<std::string> views = {R"({"buffer": 0, "byteOffset": 0, "byteLength": 48})",
                                      R"({"buffer": 0, "byteOffset": 48, "byteLength": 32})",
                                      R"({"buffer": 0, "byteOffset": 80, "byteLength": 24})"};
    views.insert(views.end(), extra_views.begin(), extra_views.end());
    std::vector<std::string> meshes, textures;
    for (size_t i = 0; i < std::max<size_t>(materials.size(), 1); ++i) {
      meshes.push_back("{\"name\": \"quad" + std::to_string(i) +
                       R"(", "primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2)" +
                       (materials.empty() ? std::string() : ", \"material\": " + std::to_string(i)) + "}]}");
    }
    for (size_t i = 0; i < images.size(); ++i) textures.push_back("{\"source\": " + std::to_string(i) + "}");
    std::vector<std::string> root_list;
    for (int r : roots) root_list.push_back(std::to_string(r));
    const std::string uri = buffer_uri.empty() ? "" : "\"uri\": \"" + buffer_uri + "\", ";
    std::ostringstream json;
    json << R"({"asset": {"version": "2.0"},)"
         << "\"extensionsUsed\": " << extensions_used << ","
         << "\"buffers\": [{" << uri << "\"byteLength\": " << buffer_size << "}],"
         << "\"bufferViews\": " << list(views) << ","
         << R"("accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",)"
         << R"( "min": [0, 0, -1], "max": [1, 0, 0]},)"
         << R"({"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},)"
         << R"({"bufferView": 2, "componentType": 5125, "count": 6, "type": "SCALAR"}],)"
         << "\"meshes\": " << list(meshes) << ",";
    if (!images.empty()) json << "\"images\": " << list(images) << ", \"textures\": " << list(textures) << ",";
    if (!materials.empty()) json << "\"materials\": " << list(materials) << ",";
    if (!lights.empty()) json << "\"extensions\": {\"KHR_lights_punctual\": {\"lights\": " << list(lights) << "}},";
    json << "\"nodes\": " << list(nodes) << ", \"scenes\": [{\"nodes\": " << list(root_list) << "}], \"scene\": 0}";
    return json.str();
  }

  // NAME.gltf with its buffer NAME.bin.
  fs::path write(const fs::path& dir, const std::string& name) const {
    const std::string bytes = buffer();
    std::ofstream(dir / (name + ".bin"), std::ios::binary) << bytes;
    const fs::path path = dir / (name + ".gltf");
    std::ofstream(path) << json(name + ".bin", bytes.size());
    return path;
  }

  // NAME.glb: the JSON chunk (padded with spaces) and the buffer's chunk (padded with zeros), as the GLB format has it.
  fs::path write_glb(const fs::path& dir, const std::string& name) const {
    std::string bytes = buffer();
    std::string text = json("", bytes.size());
    while (text.size() % 4) text += ' ';
    while (bytes.size() % 4) bytes += '\0';
    std::string glb = "glTF";
    const auto u32 = [&glb](size_t v) {
      const auto w = static_cast<uint32_t>(v);
      glb.append(reinterpret_cast<const char*>(&w), 4);
    };
    u32(2);
    u32(12 + 8 + text.size() + 8 + bytes.size());
    u32(text.size());
    glb += "JSON" + text;
    u32(bytes.size());
    glb += std::string("BIN\0", 4) + bytes;
    const fs::path path = dir / (name + ".glb");
    std::ofstream(path, std::ios::binary) << glb;
    return path;
  }
};

// A w × h PNG of one colour (8-bit sRGB values, as a base-colour texture holds).
std::string solid_png(int w, int h, uint8_t r, uint8_t g, uint8_t b) {
  image::Png8Image im;
  im.width = w;
  im.height = h;
  im.channels = 3;
  for (int i = 0; i < w * h; ++i) im.pixels.insert(im.pixels.end(), {r, g, b});
  return image::encode_png(im);
}

std::string base64(const std::string& bytes) {
  static const char* const kDigits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (size_t i = 0; i < bytes.size(); i += 3) {
    uint32_t v = static_cast<uint8_t>(bytes[i]) << 16;
    if (i + 1 < bytes.size()) v |= static_cast<uint8_t>(bytes[i + 1]) << 8;
    if (i + 2 < bytes.size()) v |= static_cast<uint8_t>(bytes[i + 2]);
    out += kDigits[v >> 18];
    out += kDigits[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? kDigits[(v >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? kDigits[v & 63] : '=';
  }
  return out;
}

const v1::SceneMaterial& material_named(const v1::LightmapJob& job, const std::string& name) {
  for (const v1::SceneMaterial& m : job.materials()) {
    if (m.name() == name) return m;
  }
  throw std::runtime_error("no material " + name);
}

const v1::Light& light_named(const v1::LightmapJob& job, const std::string& name) {
  for (const v1::Light& l : job.lights()) {
    if (l.name() == name) return l;
  }
  throw std::runtime_error("no light " + name);
}

bool has_warning(const client::ImportedScene& s, const std::string& part) {
  for (const std::string& w : s.warnings) {
    if (w.find(part) != std::string::npos) return true;
  }
  return false;
}

// glTF stores its numbers as JSON text that Assimp reads into float32, and Assimp composes node transforms in
// float32: values near 1 carry a relative error of a few 2^-24 ≈ 6e-8, so 1e-6 absolute on values of order 1 (and
// 1e-6 times the magnitude on larger ones) holds with a wide margin while catching any real mapping mistake.
constexpr double kFloat32 = 1e-6;

TEST(SceneImport, TextureWrittenWithAnotherMachinesPathIsFoundBesideTheModel) {
  // Exporters write the absolute path of the machine they ran on, often Windows's: the file beside the model is
  // the one meant.
  test::TempDir dir("kiln-import");
  const std::string wood = solid_png(2, 1, 140, 90, 40);
  std::ofstream(dir.path() / "wood.png", std::ios::binary) << wood;
  {
    std::ofstream mtl(dir.path() / "crate.mtl");
    mtl << "newmtl oak\nKd 1 1 1\nmap_Kd C:\\Users\\artist\\textures\\wood.png\n";
    std::ofstream obj(dir.path() / "crate.obj");
    obj << "mtllib crate.mtl\no crate\nv 0 0 0\nv 1 0 0\nv 1 0 1\nvt 0 0\nvt 1 0\nvt 1 1\nusemtl oak\n"
           "f 1/1 3/3 2/2\n";
  }
  const client::ImportedScene s = client::import_scene((dir.path() / "crate.obj").string());
  const v1::SceneMaterial& oak = material_named(s.job, "oak");
  ASSERT_TRUE(oak.has_base_color_texture());
  const v1::Texture& t = s.job.textures(static_cast<int>(oak.base_color_texture()));
  EXPECT_EQ(s.blobs.at(t.image().sha256()), wood);
  EXPECT_EQ(t.color_space(), "srgb_texture");
}

TEST(SceneImport, GltfBaseColourTexturesAreUploadedOnceWithTheirBytes) {
  test::TempDir dir("kiln-import");
  const std::string red = solid_png(2, 2, 255, 0, 0), green = solid_png(3, 1, 0, 255, 0),
                    blue = solid_png(1, 3, 0, 0, 255);
  std::ofstream(dir.path() / "red tile.png", std::ios::binary) << red;  // a space: "red%20tile.png" in the URI
  GltfScene g;
  g.images = {R"({"uri": "red%20tile.png"})", "{\"uri\": \"data:image/png;base64," + base64(green) + "\"}",
              "{\"bufferView\": " + std::to_string(g.add_buffer_image(blue)) + ", \"mimeType\": \"image/png\"}",
              R"({"uri": "missing.png"})"};
  g.materials = {R"({"name": "brick", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}})",
                 R"({"name": "brick_again", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}})",
                 R"({"name": "grass", "pbrMetallicRoughness": {"baseColorTexture": {"index": 1}}})",
                 R"({"name": "sea", "pbrMetallicRoughness": {"baseColorTexture": {"index": 2}}})",
                 R"({"name": "lost", "pbrMetallicRoughness": {"baseColorTexture": {"index": 3},)"
                 R"( "baseColorFactor": [0.2, 0.3, 0.4, 1]}})",
                 R"({"name": "plain", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1]}})"};
  g.place_each_mesh();
  const client::ImportedScene s = client::import_scene(g.write(dir.path(), "textured").string());
  const v1::LightmapJob& j = s.job;

  // Three images are readable (the file, the data URI, the bufferView), each one Texture, sRGB, with its bytes.
  ASSERT_EQ(j.textures_size(), 3);
  auto texture_of = [&](const std::string& material) -> const v1::Texture* {
    const v1::SceneMaterial& m = material_named(j, material);
    if (!m.has_base_color_texture()) return nullptr;
    EXPECT_LT(m.base_color_texture(), static_cast<uint32_t>(j.textures_size())) << material;
    return &j.textures(static_cast<int>(m.base_color_texture()));
  };
  const std::map<std::string, const std::string*> expected = {
      {"brick", &red}, {"brick_again", &red}, {"grass", &green}, {"sea", &blue}};
  for (const auto& [material, bytes] : expected) {
    const v1::Texture* t = texture_of(material);
    ASSERT_NE(t, nullptr) << material;
    EXPECT_EQ(t->color_space(), "srgb_texture") << material;
    EXPECT_EQ(t->image().sha256(), proto::sha256_hex(*bytes)) << material;
    EXPECT_EQ(t->image().size(), bytes->size()) << material;
    ASSERT_TRUE(s.blobs.count(t->image().sha256())) << material;
    EXPECT_EQ(s.blobs.at(t->image().sha256()), *bytes) << material << ": the uploaded bytes are the image's";
  }
  // Two materials on one image share its Texture; the blob map holds each image once.
  EXPECT_EQ(material_named(j, "brick").base_color_texture(), material_named(j, "brick_again").base_color_texture());
  std::set<std::string> blobs = {red, green, blue};  // the images, and the meshes' blobs (equal quads: one)
  for (const v1::Mesh& m : j.meshes()) blobs.insert(s.blobs.at(m.geometry().sha256()));
  EXPECT_EQ(s.blobs.size(), blobs.size());

  // The missing file: a warning naming it, and the material keeps its base colour without a texture.
  EXPECT_EQ(texture_of("lost"), nullptr);
  EXPECT_TRUE(has_warning(s, "missing.png"));
  const v1::SceneMaterial& lost = material_named(j, "lost");
  EXPECT_NEAR(lost.base_color().r(), 0.2, kFloat32);
  EXPECT_NEAR(lost.base_color().g(), 0.3, kFloat32);
  EXPECT_NEAR(lost.base_color().b(), 0.4, kFloat32);
  EXPECT_EQ(texture_of("plain"), nullptr);

  // The daemon takes the whole of it (every texture index in range, every field within its bounds).
  EXPECT_NO_THROW(translated(j));
}

TEST(SceneImport, NamesThatAreNotUtf8BecomeValidAndFilesAreFoundByTheirBytes) {
  // Latin-1 names, as in assimp-testmodels' OBJ/regr01.obj: a material "Mat\xe9riau" whose texture file is
  // "bois\xe9.png" on disk, and an object "caf\xe9". protobuf cannot parse a frame with them in a string field.
  test::TempDir dir("kiln-import");
  const std::string latin1_file = "bois\xe9.png";
  std::ofstream(dir.path() / latin1_file, std::ios::binary) << solid_png(2, 2, 200, 100, 50);
  {
    std::ofstream mtl(dir.path() / "latin1.mtl", std::ios::binary);
    mtl << "newmtl Mat\xe9riau\nKd 1 1 1\nmap_Kd " << latin1_file << "\n";
    std::ofstream obj(dir.path() / "latin1.obj", std::ios::binary);
    obj << "mtllib latin1.mtl\no caf\xe9\nv 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\n"
           "usemtl Mat\xe9riau\nf 1/1 2/2 3/3\n";
  }
  const client::ImportedScene s = client::import_scene((dir.path() / "latin1.obj").string());
  const std::string fffd = "\xef\xbf\xbd";
  bool found = false;
  for (const v1::SceneMaterial& m : s.job.materials()) {
    if (m.name() == "Mat" + fffd + "riau") {
      found = true;
      ASSERT_TRUE(m.has_base_color_texture());  // the file was read by its own bytes
      EXPECT_EQ(s.job.textures(static_cast<int>(m.base_color_texture())).name(), "bois" + fffd + ".png");
    }
  }
  EXPECT_TRUE(found);
  ASSERT_EQ(s.job.meshes_size(), 1);
  EXPECT_EQ(s.job.meshes(0).name(), "caf" + fffd);
  EXPECT_EQ(s.job.instances(0).lightmap(), "caf" + fffd);
  // The job survives the wire: what the client serialises, the daemon parses (it failed to before).
  v1::JobSpec spec;
  *spec.mutable_lightmap() = s.job;
  std::string bytes;
  ASSERT_TRUE(spec.SerializeToString(&bytes));
  v1::JobSpec parsed;
  EXPECT_TRUE(parsed.ParseFromString(bytes));
  EXPECT_NO_THROW(translated(s.job));
}

TEST(SceneImport, LongNamesAreCutWithoutCuttingACharacter) {
  // 300 bytes of 'x' then 木 (3 bytes) from byte 255: the protocol's 256 bytes would end inside it.
  test::TempDir dir("kiln-import");
  const std::string name = std::string(255, 'x') + "\xe6\x9c\xa8" + std::string(42, 'y');
  {
    std::ofstream obj(dir.path() / "long.obj", std::ios::binary);
    obj << "o " << name << "\nv 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nf 1/1 2/2 3/3\n";
  }
  const client::ImportedScene s = client::import_scene((dir.path() / "long.obj").string());
  ASSERT_EQ(s.job.meshes_size(), 1);
  EXPECT_EQ(s.job.meshes(0).name(), std::string(255, 'x'));
  EXPECT_EQ(s.job.instances(0).lightmap(), std::string(255, 'x'));
}

TEST(SceneImport, GltfMetallicRoughnessBecomesGgxOverLambert) {
  test::TempDir dir("kiln-import");
  GltfScene g;
  g.materials = {
      R"({"name": "painted", "doubleSided": true, "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.6, 0.7, 1],)"
      R"( "metallicFactor": 0.25, "roughnessFactor": 0.5}})",
      R"({"name": "polished", "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.8, 0.1, 1],)"
      R"( "metallicFactor": 1, "roughnessFactor": 0.01}})",
      R"({"name": "defaults"})"};
  g.place_each_mesh();
  const client::ImportedScene s = client::import_scene(g.write(dir.path(), "pbr").string());

  // glTF (Appendix B): c_diff = lerp(base, 0, metallic), f0 = lerp(0.04, base, metallic), α = roughness². kiln:
  // Lambert albedo (1 − metallic) times base_color, GGX with Schlick's f0, layered (the diffuse lobe gets what the
  // specular one does not reflect: glTF's fresnel_mix).
  struct Expected {
    const char* name;
    double base[3], albedo, alpha, f0[3];
    bool two_sided;
  };
  const Expected cases[] = {// 0.04 + (c − 0.04)·0.25; α = 0.5²
                            {"painted", {0.5, 0.6, 0.7}, 0.75, 0.25, {0.155, 0.18, 0.205}, true},
                            // a metal: f0 = base, no diffuse; roughness 0.01 is below the 0.03 floor, so α = 0.03²
                            {"polished", {0.9, 0.8, 0.1}, 0.0, 0.0009, {0.9, 0.8, 0.1}, false},
                            // glTF's defaults: base 1, metallic 1, roughness 1
                            {"defaults", {1, 1, 1}, 0.0, 1.0, {1, 1, 1}, false}};
  for (const Expected& e : cases) {
    SCOPED_TRACE(e.name);
    const v1::SceneMaterial& m = material_named(s.job, e.name);
    EXPECT_NEAR(m.base_color().r(), e.base[0], kFloat32);
    EXPECT_NEAR(m.base_color().g(), e.base[1], kFloat32);
    EXPECT_NEAR(m.base_color().b(), e.base[2], kFloat32);
    EXPECT_EQ(m.bsdf().combine(), v1::COMBINE_LAYERED);
    ASSERT_TRUE(m.bsdf().diffuse().has_lambert());
    const v1::Color& albedo = m.bsdf().diffuse().lambert().albedo();
    EXPECT_NEAR(albedo.r(), e.albedo, kFloat32);
    EXPECT_NEAR(albedo.g(), e.albedo, kFloat32);
    EXPECT_NEAR(albedo.b(), e.albedo, kFloat32);
    ASSERT_TRUE(m.bsdf().specular().has_ggx());
    const v1::Microfacet& ggx = m.bsdf().specular().ggx();
    EXPECT_EQ(ggx.fresnel(), v1::FRESNEL_SCHLICK);
    EXPECT_NEAR(ggx.alpha(), e.alpha, kFloat32);
    EXPECT_NEAR(ggx.f0().r(), e.f0[0], kFloat32);
    EXPECT_NEAR(ggx.f0().g(), e.f0[1], kFloat32);
    EXPECT_NEAR(ggx.f0().b(), e.f0[2], kFloat32);
    EXPECT_EQ(m.two_sided(), e.two_sided);
    EXPECT_FALSE(m.has_emission());
  }
  EXPECT_NO_THROW(translated(s.job));
}

TEST(SceneImport, GltfEmissiveMaterialsTakeTheirStrengthByIndex) {
  test::TempDir dir("kiln-import");
  GltfScene g;
  // Unnamed, and two of one name with different strengths: names cannot say which strength is whose.
  g.materials = {
      R"({"emissiveFactor": [1, 0.5, 0.25], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4}}})",
      R"({"name": "lamp", "emissiveFactor": [0.5, 0.5, 0.5],)"
      R"( "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 10}}})",
      R"({"name": "lamp", "emissiveFactor": [0.5, 0.5, 0.5]})", R"({"name": "dark"})"};
  g.place_each_mesh();
  const client::ImportedScene s = client::import_scene(g.write(dir.path(), "emissive").string());
  const v1::LightmapJob& j = s.job;
  ASSERT_GE(j.materials_size(), 4);  // Assimp appends its default material after the file's
  // Material i of the file is material i of the job, with emission = emissiveFactor × emissiveStrength.
  const double expected[4][3] = {{4, 2, 1}, {5, 5, 5}, {0.5, 0.5, 0.5}, {0, 0, 0}};
  for (int i = 0; i < 4; ++i) {
    SCOPED_TRACE(i);
    const v1::SceneMaterial& m = j.materials(i);
    EXPECT_EQ(m.has_emission(), i < 3);
    EXPECT_NEAR(m.emission().r(), expected[i][0], kFloat32 * 10);  // 10: the largest value's magnitude
    EXPECT_NEAR(m.emission().g(), expected[i][1], kFloat32 * 10);
    EXPECT_NEAR(m.emission().b(), expected[i][2], kFloat32 * 10);
  }
  EXPECT_FALSE(j.materials(0).name().empty());  // an unnamed material gets a name for people
  EXPECT_EQ(j.materials(1).name(), "lamp");
  EXPECT_EQ(j.materials(2).name(), "lamp#1");  // kiln wants material names unique
  EXPECT_NO_THROW(translated(j));
}

// The extensions Assimp does not pass on are read from a GLB's JSON chunk as from a .gltf: emissive strength and
// KHR_materials_specular's "no specular lobe".
TEST(SceneImport, GlbExtensionsAreReadFromItsJsonChunk) {
  test::TempDir dir("kiln-import");
  GltfScene g;
  g.extensions_used = R"(["KHR_materials_emissive_strength", "KHR_materials_specular"])";
  g.materials = {
      R"({"emissiveFactor": [1, 0.5, 0.25], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4}}})",
      R"({"name": "matte", "pbrMetallicRoughness": {"metallicFactor": 0},)"
      R"( "extensions": {"KHR_materials_specular": {"specularColorFactor": [0, 0, 0]}}})",
      R"({"name": "plain", "pbrMetallicRoughness": {"metallicFactor": 0}})"};
  g.place_each_mesh();
  const client::ImportedScene s = client::import_scene(g.write_glb(dir.path(), "extras").string());
  ASSERT_GE(s.job.materials_size(), 2);
  const v1::SceneMaterial& lamp = s.job.materials(0);
  EXPECT_NEAR(lamp.emission().r(), 4, kFloat32 * 4);  // emissiveFactor × emissiveStrength
  EXPECT_NEAR(lamp.emission().g(), 2, kFloat32 * 4);
  EXPECT_NEAR(lamp.emission().b(), 1, kFloat32 * 4);
  EXPECT_FALSE(material_named(s.job, "matte").bsdf().has_specular());  // specularColorFactor 0
  EXPECT_TRUE(material_named(s.job, "plain").bsdf().has_specular());   // glTF's 4 % dielectric
  EXPECT_NO_THROW(translated(s.job));
}

TEST(SceneImport, GltfMeshPlacedByTwoNodesGetsALightmapOfItsOwnPerNodeAndItsName) {
  test::TempDir dir("kiln-import");
  GltfScene g;
  g.materials = {R"({"name": "m"})"};
  // Two nodes of one name placing mesh 0: each placement needs its own texels and a name that is a file name.
  g.nodes = {R"({"name": "Post/A", "mesh": 0})", R"({"name": "Post/A", "mesh": 0, "translation": [3, 0, 0]})",
             R"({"name": "Other", "mesh": 0, "translation": [6, 0, 0]})"};
  g.roots = {0, 1, 2};
  const client::ImportedScene s = client::import_scene(g.write(dir.path(), "twice").string());
  ASSERT_EQ(s.job.instances_size(), 3);
  EXPECT_EQ(s.job.instances(0).lightmap(), "quad0@Post/A");
  EXPECT_EQ(s.job.instances(1).lightmap(), "quad0@Post/A#1");
  EXPECT_EQ(s.job.instances(2).lightmap(), "quad0@Other");
  EXPECT_EQ(s.job.instances(0).mesh(), s.job.instances(1).mesh());
  // Each instance is named by its node, as it was written (lightmaps.json lists instances by it).
  EXPECT_EQ(s.job.instances(0).name(), "Post/A");
  EXPECT_EQ(s.job.instances(1).name(), "Post/A");
  EXPECT_EQ(s.job.instances(2).name(), "Other");
  // kilnd's scene check turns each into a plain file name of its own.
  const daemon::BakeRequest r = translated(s.job);
  const auto* in = std::get_if<lightmap::LightmapBakeInput>(&r.input);
  ASSERT_NE(in, nullptr);
  const scene::CheckedScene checked = scene::check_scene(in->scene);
  std::set<std::string> stems;
  for (const scene::Instance& i : checked.scene.instances) {
    EXPECT_EQ(i.lightmap.find('/'), std::string::npos) << i.lightmap;
    stems.insert(i.lightmap);
  }
  EXPECT_EQ(stems, (std::set<std::string>{"quad0@Post_A", "quad0@Post_A#1", "quad0@Other"}));
}

TEST(SceneImport, GltfSpecularAndIorExtensionsSetTheDielectricF0) {
  test::TempDir dir("kiln-import");
  GltfScene g;
  g.extensions_used = R"(["KHR_materials_specular", "KHR_materials_ior"])";
  const std::string dielectric = R"("pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0})";
  g.materials = {
      // specularColorFactor 0: no specular lobe at all (today's glTF exporters write this for matte surfaces)
      R"({"name": "matte", )" + dielectric + R"(, "extensions": {"KHR_materials_specular": )"
                                             R"({"specularColorFactor": [0, 0, 0]}}})",
      R"({"name": "weak", )" + dielectric + R"(, "extensions": {"KHR_materials_specular": )"
                                            R"({"specularFactor": 0, "specularColorFactor": [1, 1, 1]}}})",
      // f0 = 0.04 · (1, 0.5, 0.25) · 0.5
      R"({"name": "tinted", )" + dielectric + R"(, "extensions": {"KHR_materials_specular": )"
                                              R"({"specularFactor": 0.5, "specularColorFactor": [1, 0.5, 0.25]}}})",
      // ior 2: ((2 − 1)/(2 + 1))² = 1/9, times the colour; 20/9 is clamped to 1
      R"({"name": "dense", )" + dielectric + R"(, "extensions": {"KHR_materials_ior": {"ior": 2}, )"
                                             R"("KHR_materials_specular": {"specularColorFactor": [20, 1, 0.5]}}})",
      // a half-metal over a matte dielectric: f0 = lerp(0, base, 0.5) = base / 2
      R"({"name": "half_metal", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.6, 0.4, 1], )"
      R"("metallicFactor": 0.5}, "extensions": {"KHR_materials_specular": {"specularColorFactor": [0, 0, 0]}}})",
      R"({"name": "plain", )" + dielectric + "}"};
  g.place_each_mesh();
  const client::ImportedScene s = client::import_scene(g.write(dir.path(), "specular").string());
  EXPECT_FALSE(material_named(s.job, "matte").bsdf().has_specular());
  EXPECT_FALSE(material_named(s.job, "weak").bsdf().has_specular());
  const double expected[4][3] = {
      {0.04 * 0.5, 0.04 * 0.25, 0.04 * 0.125}, {1.0, 1.0 / 9, 0.5 / 9}, {0.4, 0.3, 0.2}, {0.04, 0.04, 0.04}};
  const char* names[4] = {"tinted", "dense", "half_metal", "plain"};
  for (int k = 0; k < 4; ++k) {
    SCOPED_TRACE(names[k]);
    const v1::SceneMaterial& m = material_named(s.job, names[k]);
    ASSERT_TRUE(m.bsdf().specular().has_ggx());
    const v1::Color& f0 = m.bsdf().specular().ggx().f0();
    EXPECT_NEAR(f0.r(), expected[k][0], kFloat32);
    EXPECT_NEAR(f0.g(), expected[k][1], kFloat32);
    EXPECT_NEAR(f0.b(), expected[k][2], kFloat32);
  }
  // The diffuse lobe is glTF's c_diff whatever the specular extension says.
  EXPECT_NEAR(material_named(s.job, "matte").bsdf().diffuse().lambert().albedo().r(), 1.0, kFloat32);
  EXPECT_NO_THROW(translated(s.job));
}

TEST(SceneImport, GltfExtensionsAndTexturesKilnDoesNotReadAreWarnings) {
  test::TempDir dir("kiln-import");
  GltfScene g;
  g.extensions_used = R"(["KHR_materials_clearcoat", "KHR_materials_specular", "KHR_texture_transform"])";
  g.images = {R"({"uri": "n.png"})"};
  g.materials = {R"({"name": "a", "normalTexture": {"index": 0}, "occlusionTexture": {"index": 0}})",
                 R"({"name": "b", "normalTexture": {"index": 0}})"};
  g.place_each_mesh();
  std::ofstream(dir.path() / "n.png", std::ios::binary) << solid_png(1, 1, 128, 128, 255);
  const client::ImportedScene s = client::import_scene(g.write(dir.path(), "unread").string());
  EXPECT_TRUE(has_warning(s, "KHR_materials_clearcoat: not read"));
  EXPECT_TRUE(has_warning(s, "KHR_texture_transform: not read"));
  EXPECT_FALSE(has_warning(s, "KHR_materials_specular"));  // read
  EXPECT_TRUE(has_warning(s, "normalTexture of materials a, b"));
  EXPECT_TRUE(has_warning(s, "occlusionTexture of material a"));
}

TEST(SceneImport, ObjWithoutSpecularHasNoSpecularLobe) {
  test::TempDir dir("kiln-import");
  std::ofstream(dir.path() / "m.mtl") << "newmtl matte\nKd 0.5 0.5 0.5\nnewmtl shiny\nKd 0.5 0.5 0.5\nKs 0.2 0.2 0.2\n"
                                         "Ns 100\n";
  std::ofstream(dir.path() / "m.obj") << "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\n"
                                         "vt 0 1\no a\nusemtl matte\nf 1/1 2/2 3/3\no b\nusemtl shiny\nf 1/1 3/3 4/4\n";
  const client::ImportedScene s = client::import_scene((dir.path() / "m.obj").string());
  // Schlick's term with f0 = 0 is not nothing: it reflects at grazing angles. A matte OBJ material has no lobe.
  EXPECT_FALSE(material_named(s.job, "matte").bsdf().has_specular());
  ASSERT_TRUE(material_named(s.job, "shiny").bsdf().specular().has_ggx());
  EXPECT_NEAR(material_named(s.job, "shiny").bsdf().specular().ggx().f0().r(), 0.2, kFloat32);
}

// A quaternion (x, y, z, w) as glTF writes it, for a rotation by `angle` about a unit axis.
std::string quaternion(double ax, double ay, double az, double angle) {
  std::ostringstream q;
  q.precision(17);
  const double s = std::sin(angle / 2);
  q << "[" << ax * s << ", " << ay * s << ", " << az * s << ", " << std::cos(angle / 2) << "]";
  return q.str();
}

TEST(SceneImport, GltfPunctualLightsArePlacedByTheirNodes) {
  test::TempDir dir("kiln-import");
  GltfScene g;
  g.lights = {R"({"name": "bulb", "type": "point", "color": [1, 0.5, 0.25], "intensity": 10, "range": 7})",
              R"({"name": "cone", "type": "spot", "color": [1, 1, 1], "intensity": 20,)"
              R"( "spot": {"innerConeAngle": 0.3, "outerConeAngle": 0.6}})",
              R"({"type": "directional", "color": [1, 1, 0.5], "intensity": 3})"};
  const double kPi = 3.14159265358979323846;
  g.nodes = {R"({"name": "floor", "mesh": 0})",
             // 1: a parent moved to (10, 0, 0), scaled by 2, turned 90° about +Y: its children's (x, y, z) land at
             // (10 + 2z, 2y, −2x), and their directions turn (x, y, z) → (z, y, −x).
             "{\"name\": \"rig\", \"translation\": [10, 0, 0], \"scale\": [2, 2, 2], \"rotation\": " +
                 quaternion(0, 1, 0, kPi / 2) + ", \"children\": [2, 3]}",
             // 2: the point light at (1, 2, 3) in the rig: (10 + 6, 4, −2) in the world.
             R"({"name": "bulb_node", "translation": [1, 2, 3], "extensions": {"KHR_lights_punctual": {"light": 0}}})",
             // 3: the spot at (0, 5, 1) in the rig, turned −45° about +X: it shines along −Z turned, (0, −√½, −√½),
             // which the rig turns to (−√½, −√½, 0); its position is (10 + 2, 10, 0).
             "{\"name\": \"cone_node\", \"translation\": [0, 5, 1], \"rotation\": " + quaternion(1, 0, 0, -kPi / 4) +
                 ", \"extensions\": {\"KHR_lights_punctual\": {\"light\": 1}}}",
             // 4: the sun turned −60° about +X at the root: −Z becomes (0, −sin 60°, −cos 60°).
             "{\"name\": \"sun_node\", \"translation\": [0, 100, 0], \"rotation\": " + quaternion(1, 0, 0, -kPi / 3) +
                 ", \"extensions\": {\"KHR_lights_punctual\": {\"light\": 2}}}"};
  g.roots = {0, 1, 4};
  const client::ImportedScene s = client::import_scene(g.write(dir.path(), "lit").string());
  const v1::LightmapJob& j = s.job;
  ASSERT_EQ(j.lights_size(), 3);
  auto expect_vec = [](const v1::Vector3& v, double x, double y, double z, double magnitude) {
    EXPECT_NEAR(v.x(), x, kFloat32 * magnitude);
    EXPECT_NEAR(v.y(), y, kFloat32 * magnitude);
    EXPECT_NEAR(v.z(), z, kFloat32 * magnitude);
  };
  auto expect_color = [](const v1::Color& c, double r, double g, double b, double magnitude) {
    EXPECT_NEAR(c.r(), r, kFloat32 * magnitude);
    EXPECT_NEAR(c.g(), g, kFloat32 * magnitude);
    EXPECT_NEAR(c.b(), b, kFloat32 * magnitude);
  };
  // Lights are named after their nodes. Colours are color × intensity: glTF's candela → kiln's W/sr for point and
  // spot lights and lux → W/m² for directional ones, number for number (the importer's documented mapping).
  const v1::Light& bulb = light_named(j, "bulb_node");
  ASSERT_TRUE(bulb.has_point());
  expect_color(bulb.color(), 10, 5, 2.5, 10);
  expect_vec(bulb.point().position(), 16, 4, -2, 16);
  EXPECT_TRUE(has_warning(s, "range 7 ignored"));  // kiln's lights have no cut-off

  const v1::Light& cone = light_named(j, "cone_node");
  ASSERT_TRUE(cone.has_spot());
  expect_color(cone.color(), 20, 20, 20, 20);
  expect_vec(cone.spot().position(), 12, 10, 0, 12);
  expect_vec(cone.spot().direction(), -std::sqrt(0.5), -std::sqrt(0.5), 0, 1);
  // glTF's cone angles are half-angles from the axis, as kiln's: carried over unchanged.
  EXPECT_NEAR(cone.spot().inner_cone_angle(), 0.3, kFloat32);
  EXPECT_NEAR(cone.spot().outer_cone_angle(), 0.6, kFloat32);

  const v1::Light& sun = light_named(j, "sun_node");
  ASSERT_TRUE(sun.has_directional());
  expect_color(sun.color(), 3, 3, 1.5, 3);
  expect_vec(sun.directional().direction(), 0, -std::sqrt(3.0) / 2, -0.5, 1);
  EXPECT_FALSE(sun.directional().has_angular_diameter());  // the daemon's default: the sun's disc

  // Through the daemon's translation: the lights as the baker will see them.
  const daemon::BakeRequest r = translated(j);
  ASSERT_EQ(r.lightmap().scene.lights.size(), 3u);
  for (const scene::Light& l : r.lightmap().scene.lights) {
    if (l.type == scene::LightShape::spot) {
      EXPECT_NEAR(l.inner_cone, 0.3, kFloat32);
      EXPECT_NEAR(l.outer_cone, 0.6, kFloat32);
    }
    if (l.type == scene::LightShape::directional) {
      EXPECT_GT(l.angular_diameter, 0.009);  // the sun's, about 0.0093 rad
      EXPECT_LT(l.angular_diameter, 0.0095);
    }
  }
}

TEST(MeshBlobRoundTrip, EncodeThenDecodeGivesTheSameArrays) {
  client::MeshArrays a;
  a.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0.5f}};
  a.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}, {0, 0.6f, 0.8f}};
  a.uv = {{0, 0}, {1, 0}, {0, 1}, {1, 1}};
  a.lightmap_uv = {{0.1f, 0.1f}, {0.9f, 0.1f}, {0.1f, 0.9f}, {0.9f, 0.9f}};
  a.indices = {0, 1, 2, 2, 1, 3};
  a.materials = {0, 3};
  for (int variant = 0; variant < 2; ++variant) {
    if (variant == 1) {  // the optional arrays left out
      a.normals.clear();
      a.uv.clear();
      a.materials.clear();
    }
    const scene::Mesh m = daemon::decode_mesh_blob(client::encode_mesh_blob(a), "mesh", "m");
    ASSERT_EQ(m.positions.size(), a.positions.size());
    for (std::size_t i = 0; i < a.positions.size(); ++i) {
      // float32 → double → compared as float32: exact.
      EXPECT_EQ(static_cast<float>(m.positions[i].z), a.positions[i][2]);
      EXPECT_EQ(static_cast<float>(m.lightmap_uv[i].y), a.lightmap_uv[i][1]);
    }
    EXPECT_EQ(m.normals.size(), a.normals.size());
    EXPECT_EQ(m.uv.size(), a.uv.size());
    EXPECT_EQ(m.indices, a.indices);
    EXPECT_EQ(m.material, a.materials);
  }
  client::MeshArrays bad = a;
  bad.normals = {{0, 0, 1}};
  EXPECT_THROW(client::encode_mesh_blob(bad), std::invalid_argument);
  bad = a;
  bad.indices.push_back(0);
  EXPECT_THROW(client::encode_mesh_blob(bad), std::invalid_argument);
}

}  // namespace
}  // namespace kiln
