// The scene importer on the project's own Cornell box (client/examples/scenes/cornell_box.py, written into a temporary
// folder) and on a tiny OBJ written here: meshes, lightmap UVs, instances and their lightmaps, materials (the emissive
// strength Assimp 5.2 ignores), and the mesh blobs, which must decode with the daemon's decoder to the same arrays.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

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
fs::path source_dir() { return fs::path(__FILE__).parent_path().parent_path().parent_path(); }

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

TEST(SceneImport, CornellBoxMeshesUvsInstancesAndEmission) {
  test::TempDir dir("kiln-import");
  const client::ImportedScene s = client::import_scene(cornell_box(dir.path()).string());
  const v1::LightmapJob& j = s.job;
  std::map<std::string, int> meshes;
  for (int i = 0; i < j.meshes_size(); ++i) meshes[j.meshes(i).name()] = i;
  for (const char* name : {"floor", "ceiling", "back_wall", "left_wall", "right_wall", "short_block", "tall_block",
                           "light"}) {
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
  v1::JobSpec spec;
  *spec.mutable_lightmap() = j;
  EXPECT_NO_THROW(daemon::translate(spec));
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

TEST(SceneImport, UnreadableFilesAreErrorsForPeople) {
  test::TempDir dir("kiln-import");
  try {
    client::import_scene((dir.path() / "missing.gltf").string());
    ADD_FAILURE() << "imported a missing file";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("missing.gltf"), std::string::npos) << e.what();
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
