// Lightmap names become file stems that are plain, portable and unique, and stay as they are when already safe.
#include <gtest/gtest.h>

#include <string>

#include "bakers/scene/lightmap_file_names.h"
#include "bakers/scene/scene_check.h"

namespace kiln::scene {
namespace {

TEST(LightmapFileNames, SafeNamesAreKeptAsTheyAre) {
  for (const char* name : {"Floor", "wall-01", "page0", "Chair@Node 3", "pièce_é", "a.b.c", "x#1"}) {
    EXPECT_EQ(safe_file_stem(name), name);
  }
}

TEST(LightmapFileNames, PathsReservedCharactersAndHiddenNamesBecomePlainNames) {
  EXPECT_EQ(safe_file_stem("Node/Mesh"), "Node_Mesh");
  EXPECT_EQ(safe_file_stem("..\\..\\etc"), "_._.._etc");
  EXPECT_EQ(safe_file_stem(".."), "__");
  EXPECT_EQ(safe_file_stem("."), "_");
  EXPECT_EQ(safe_file_stem(".hidden"), "_hidden");
  EXPECT_EQ(safe_file_stem("a:b*c?d\"e<f>g|h"), "a_b_c_d_e_f_g_h");
  EXPECT_EQ(safe_file_stem(std::string("tab\there\nnew\x7f")), "tab_here_new_");
  EXPECT_EQ(safe_file_stem("trailing. ."), "trailing___");
  EXPECT_EQ(safe_file_stem(""), "lightmap");
}

TEST(LightmapFileNames, LongNamesAreCutWithoutCuttingACharacter) {
  // 199 ASCII bytes then a 2-byte character: the cut at 200 would split it, so the stem keeps 199 bytes.
  const std::string name = std::string(199, 'x') + "é" + "tail";
  const std::string stem = safe_file_stem(name);
  EXPECT_EQ(stem, std::string(199, 'x'));
  EXPECT_LE(safe_file_stem(std::string(1000, 'y')).size(), kMaxLightmapStemBytes);
}

TEST(LightmapFileNames, StemsAreUniqueIgnoringAsciiCaseAndStablePerName) {
  LightmapFileNames files;
  EXPECT_EQ(files.stem("a/b"), "a_b");
  EXPECT_EQ(files.stem("a_b"), "a_b-2");  // safe itself, but a/b took its file name first
  EXPECT_EQ(files.stem("A_B"), "A_B-3");  // one file on Windows and macOS
  EXPECT_EQ(files.stem("a/b"), "a_b");    // the same name, the same stem
  EXPECT_EQ(files.stem("Floor"), "Floor");
  const auto renamed = files.renamed();
  EXPECT_EQ(renamed.size(), 3u);
  EXPECT_EQ(renamed.at("a/b"), "a_b");
  EXPECT_EQ(renamed.at("a_b"), "a_b-2");
  EXPECT_EQ(renamed.at("A_B"), "A_B-3");
  // A suffix never pushes a long stem over the limit.
  LightmapFileNames long_names;
  const std::string x(300, 'x');
  long_names.stem(x);
  EXPECT_LE(long_names.stem(x + "y").size(), kMaxLightmapStemBytes);
  EXPECT_NE(long_names.stem(x + "y"), long_names.stem(x));
}

// A square in the XZ plane with lightmap UVs, as two triangles.
Mesh quad(const std::string& name) {
  Mesh m;
  m.name = name;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {1, 0, -1}, {0, 0, -1}};
  m.lightmap_uv = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  m.indices = {0, 1, 2, 0, 2, 3};
  return m;
}

TEST(LightmapFileNames, TheSceneCheckNamesEachLightmapByItsStemAndReportsTheChange) {
  Scene s;
  s.meshes = {quad("Chair/Seat"), quad("floor")};
  s.materials.push_back({});
  Instance a, b, c;
  a.mesh = 0;  // no lightmap name: the mesh's, which is not a file name
  b.mesh = 1;
  b.lightmap = "Floor";
  c.mesh = 1;
  c.lightmap = "floor";  // the same file as "Floor" on Windows and macOS
  c.lightmap_scale_offset = {0.5, 0.5, 0.5, 0.5};
  s.instances = {a, b, c};
  const CheckedScene checked = check_scene(s);
  ASSERT_EQ(checked.scene.instances.size(), 3u);
  EXPECT_EQ(checked.scene.instances[0].lightmap, "Chair_Seat");
  EXPECT_EQ(checked.scene.instances[1].lightmap, "Floor");
  EXPECT_EQ(checked.scene.instances[2].lightmap, "floor-2");
  EXPECT_EQ(checked.input_lightmap_name("Chair_Seat"), "Chair/Seat");
  EXPECT_EQ(checked.input_lightmap_name("floor-2"), "floor");
  EXPECT_EQ(checked.input_lightmap_name("Floor"), "Floor");
  EXPECT_EQ(checked.report.count(ProblemKind::renamed_lightmap), 2);
  for (const Problem& p : checked.report.problems) {
    if (p.kind != ProblemKind::renamed_lightmap) continue;
    EXPECT_EQ(p.severity, Severity::warning);
    EXPECT_NE(p.action.find("_irradiance.exr"), std::string::npos) << p.action;
  }
}

}  // namespace
}  // namespace kiln::scene
