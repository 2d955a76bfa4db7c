// Generated lightmap UVs in the bake (bakers/lightmap/lightmap_uvgen.h): a mesh without them bakes with generated
// ones, NAME_uv.bin and report.json's generated_uvs say so, `never` leaves it unbaked, a mirrored character's halves
// get texels of their own, the same scene gives the same NAME_uv.bin bytes, and atlas pages pack the generated UVs.
#include <gtest/gtest.h>

#include <cstring>

#include <nlohmann/json.hpp>

#include "bakers/lightmap/lightmap_bake.h"
#include "bakers/uvgen/uv_quality.h"
#include "tests/support/test_scenes.h"
#include "tests/support/uv_shapes.h"

namespace kiln::lightmap {
namespace {

using Json = nlohmann::json;

// The blob (its texture UVs mirrored and, with `mirrored_lightmap`, its lightmap UVs too) under a constant sky.
LightmapBakeInput blob_input(bool mirrored_lightmap, uvgen::GenerateUvs mode) {
  scene::Scene s;
  s.materials.push_back(test::lambert_material("grey", 0.5));
  scene::Mesh blob = test::uv_blob(mirrored_lightmap);
  blob.name = "blob";
  s.meshes.push_back(std::move(blob));
  s.instances.push_back({});
  s.environment.constant = Rgb{1.0};
  LightmapBakeInput in = test::lightmap_input(std::move(s), 32, 0.2);
  in.max_samples = 16;
  in.padding = 2;
  in.generate_uvs = mode;
  return in;
}

// The mesh of a NAME_uv.bin (the kiln mesh layout with normals and both UV sets, as the bake writes the blob).
scene::Mesh decode(const std::string& b) {
  EXPECT_EQ(b.substr(0, 8), "KILNMSH1");
  uint32_t nv = 0, nt = 0, flags = 0;
  std::memcpy(&nv, b.data() + 8, 4);
  std::memcpy(&nt, b.data() + 12, 4);
  std::memcpy(&flags, b.data() + 16, 4);
  EXPECT_EQ(flags & 7u, 7u);  // normals, texture UVs, lightmap UVs
  EXPECT_EQ(b.size(), 20 + nv * (12 + 12 + 8 + 8) + nt * 12u + ((flags & 8u) ? nt * 4u : 0u));
  scene::Mesh m;
  const char* p = b.data() + 20;
  auto f = [&] {
    float v;
    std::memcpy(&v, p, 4);
    p += 4;
    return static_cast<double>(v);
  };
  for (uint32_t i = 0; i < nv; ++i) m.positions.push_back({f(), f(), f()});
  for (uint32_t i = 0; i < nv; ++i) m.normals.push_back({f(), f(), f()});
  for (uint32_t i = 0; i < nv; ++i) m.uv.push_back({f(), f()});
  for (uint32_t i = 0; i < nv; ++i) m.lightmap_uv.push_back({f(), f()});
  m.indices.resize(3 * nt);
  std::memcpy(m.indices.data(), p, 12 * nt);
  return m;
}

TEST(LightmapUvgen, AMeshWithoutLightmapUvsBakesWithGeneratedOnes) {
  const LightmapBakeResult r = bake_lightmaps(blob_input(false, uvgen::GenerateUvs::automatic));
  const Json report = Json::parse(test::find_output(r, "report.json").bytes);
  ASSERT_EQ(report["generated_uvs"]["mode"], "auto");
  ASSERT_EQ(report["generated_uvs"]["meshes"].size(), 1u);
  const Json& g = report["generated_uvs"]["meshes"][0];
  EXPECT_EQ(g["name"], "blob");
  EXPECT_EQ(g["reason"], "no lightmap UVs");
  EXPECT_EQ(g["file"], "blob_uv.bin");
  EXPECT_EQ(g["overlaps"], 0);
  EXPECT_EQ(g["atlas_size"], 32);  // packed for the lightmap's resolution
  EXPECT_GT(g["charts"].get<int>(), 1);
  const image::FloatImage validity = image::decode_exr(test::find_output(r, "blob_validity.exr").bytes);
  int valid = 0;
  for (float v : validity.pixels) valid += v == 1.0f;
  // The blob's charts cover about a third of their square (uvgen_bench), less at 32² where the padding around its
  // ~50 charts takes more of it: an eighth is a floor that only a failed generation (no texel) would break.
  EXPECT_GT(valid, 32 * 32 / 8);
  const scene::Mesh m = decode(test::find_output(r, "blob_uv.bin").bytes);
  const scene::Mesh input = test::uv_blob(false);
  EXPECT_EQ(m.indices.size(), input.indices.size());
  EXPECT_GE(m.positions.size(), input.positions.size());
  EXPECT_EQ(uvgen::measure_uv_quality(m).overlaps, 0);
}

TEST(LightmapUvgen, NeverLeavesAMeshWithoutUvsUnbaked) {
  EXPECT_THROW(bake_lightmaps(blob_input(false, uvgen::GenerateUvs::never)), bake::InvalidInput);
}

// The mirrored character: with its own UVs both halves bake into the same texels (the scene check reports the
// overlaps); with generated ones none overlap, so each half has texels of its own.
TEST(LightmapUvgen, MirroredHalvesGetTexelsOfTheirOwn) {
  const LightmapBakeResult own = bake_lightmaps(blob_input(true, uvgen::GenerateUvs::never));
  const Json own_report = Json::parse(test::find_output(own, "report.json").bytes);
  bool overlapping = false;
  for (const auto& line : own_report["scene_problems"]["listed"])
    overlapping |= line.get<std::string>().rfind("overlapping_lightmap_uv", 0) == 0;
  EXPECT_TRUE(overlapping);
  EXPECT_TRUE(own_report["generated_uvs"]["meshes"].empty());

  const LightmapBakeResult gen = bake_lightmaps(blob_input(true, uvgen::GenerateUvs::automatic));
  const Json report = Json::parse(test::find_output(gen, "report.json").bytes);
  for (const auto& line : report["scene_problems"]["listed"])
    EXPECT_NE(line.get<std::string>().rfind("overlapping_lightmap_uv", 0), 0u) << line;
  const Json& g = report["generated_uvs"]["meshes"][0];
  EXPECT_NE(g["reason"].get<std::string>().find("overlap"), std::string::npos) << g["reason"];
  EXPECT_EQ(g["overlaps"], 0);
}

TEST(LightmapUvgen, SameSceneSameUvBytes) {
  const LightmapBakeResult a = bake_lightmaps(blob_input(true, uvgen::GenerateUvs::always));
  const LightmapBakeResult b = bake_lightmaps(blob_input(true, uvgen::GenerateUvs::always));
  EXPECT_EQ(test::find_output(a, "blob_uv.bin").bytes, test::find_output(b, "blob_uv.bin").bytes);
  const Json report = Json::parse(test::find_output(a, "report.json").bytes);
  EXPECT_EQ(report["generated_uvs"]["meshes"][0]["reason"], "always");
}

// With atlas pages the charts are packed at the job's texel density, and the atlas then gives the mesh about that
// many texels per metre (its region's reached density).
TEST(LightmapUvgen, AtlasPagesPackGeneratedUvsAtTheTexelDensity) {
  LightmapBakeInput in = blob_input(false, uvgen::GenerateUvs::automatic);
  in.atlas.texel_density = 20;
  in.atlas.page_size = 256;
  const LightmapBakeResult r = bake_lightmaps(in);
  const Json report = Json::parse(test::find_output(r, "report.json").bytes);
  const Json& g = report["generated_uvs"]["meshes"][0];
  EXPECT_DOUBLE_EQ(g["texels_per_unit"].get<double>(), 20.0);
  EXPECT_EQ(g["overlaps"], 0);
  const double reached = report["atlas"]["regions"][0]["texel_density"].get<double>();
  // The atlas measures density over the surface area (k·√(A_uv/A_w)); the charts' UV area equals their surface
  // area at 20 texels per metre, so the reached density is 20 up to float rounding of the UVs.
  EXPECT_NEAR(reached, 20.0, 0.2);
}

}  // namespace
}  // namespace kiln::lightmap
