// Generated lightmap UVs through the service (issue 18): `kiln bake lightmap` on an OBJ character whose only UVs are
// mirrored texture UVs (the importer takes them as lightmap UVs, and both halves overlap) bakes with generated UVs by
// default: report.json's generated_uvs names the mesh with no overlap, MESH_uv.bin comes back with the lightmaps,
// the same job again is a cache hit with the same bytes, and --generate-uvs never bakes the mirrored halves into
// the same texels (the scene check reports the overlaps).
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>

#include <nlohmann/json.hpp>

#include "tests/integration/daemon_fixture.h"
#include "tests/support/run_command.h"
#include "tests/support/uv_shapes.h"

namespace kiln {
namespace {

namespace fs = std::filesystem;
using test::Daemon;

#ifdef KILN_BIN
std::string run_kiln(const Daemon& d, const std::string& args, int& status) {
  const fs::path token = d.dir() / "cli-token";
  if (!fs::exists(token)) std::ofstream(token) << d.token() << "\n";
  const test::CommandResult r = test::run_command(std::string(KILN_BIN) + " --server " + d.tcp() + " --token-file " +
                                                  token.string() + " " + args + " 2>&1");
  status = r.status;
  return r.output;
}

std::string read(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// The blob as an OBJ: positions, its mirrored texture UVs, triangles.
void write_obj(const fs::path& path) {
  const scene::Mesh m = test::uv_blob(false);
  std::ofstream o(path);
  o << "o character\n";
  for (const Vec3& p : m.positions) o << "v " << p.x << " " << p.y << " " << p.z << "\n";
  for (const Point2& t : m.uv) o << "vt " << t.x << " " << 1 - t.y << "\n";
  for (size_t t = 0; t + 2 < m.indices.size(); t += 3) {
    o << "f";
    for (int c = 0; c < 3; ++c) o << " " << m.indices[t + c] + 1 << "/" << m.indices[t + c] + 1;
    o << "\n";
  }
}

bool lists_overlaps(const nlohmann::json& report) {
  for (const auto& line : report["scene_problems"]["listed"])
    if (line.get<std::string>().rfind("overlapping_lightmap_uv", 0) == 0) return true;
  return false;
}

TEST(UvgenService, AMirroredCharacterBakesWithGeneratedUvsEndToEnd) {
  Daemon d;
  const fs::path obj = d.dir() / "character.obj";
  write_obj(obj);
  const std::string args =
      "bake lightmap " + obj.string() + " --resolution 64 --env-constant 1 --target-error 0.2 --max-samples 16 --out ";
  int status = -1;
  const fs::path out = d.dir() / "out";
  const std::string said = run_kiln(d, args + out.string(), status);
  ASSERT_EQ(status, 0) << said;

  const nlohmann::json report = nlohmann::json::parse(read(out / "report.json"));
  ASSERT_EQ(report["generated_uvs"]["meshes"].size(), 1u) << report.dump(2);
  const nlohmann::json& g = report["generated_uvs"]["meshes"][0];
  EXPECT_NE(g["reason"].get<std::string>().find("overlap"), std::string::npos) << g.dump();
  EXPECT_EQ(g["overlaps"], 0);
  EXPECT_GT(g["charts"].get<int>(), 1);
  EXPECT_FALSE(lists_overlaps(report));
  const fs::path uv = out / g["file"].get<std::string>();
  ASSERT_TRUE(fs::exists(uv)) << uv;
  const std::string bytes = read(uv);
  ASSERT_GE(bytes.size(), 20u);
  EXPECT_EQ(bytes.substr(0, 8), "KILNMSH1");
  uint32_t flags = 0;
  std::memcpy(&flags, bytes.data() + 16, 4);
  EXPECT_TRUE(flags & 4u) << "lightmap UVs in the mesh layout";

  // The same job: a cache hit, the same generated mesh.
  const fs::path again = d.dir() / "again";
  const std::string said_again = run_kiln(d, args + again.string(), status);
  ASSERT_EQ(status, 0) << said_again;
  EXPECT_NE(said_again.find("cache hit"), std::string::npos) << said_again;
  EXPECT_EQ(read(again / g["file"].get<std::string>()), bytes);

  // --generate-uvs never: the mirrored halves share texels (the overlaps are reported), and no mesh is written.
  const fs::path never = d.dir() / "never";
  const std::string said_never = run_kiln(d, args + never.string() + " --generate-uvs never", status);
  ASSERT_EQ(status, 0) << said_never;
  const nlohmann::json never_report = nlohmann::json::parse(read(never / "report.json"));
  EXPECT_TRUE(never_report["generated_uvs"]["meshes"].empty());
  EXPECT_TRUE(lists_overlaps(never_report));
  EXPECT_FALSE(fs::exists(never / g["file"].get<std::string>()));

  // A mode the CLI does not know is refused before anything is sent.
  const std::string said_bad = run_kiln(d, args + never.string() + " --generate-uvs sometimes", status);
  EXPECT_NE(status, 0);
  EXPECT_NE(said_bad.find("--generate-uvs"), std::string::npos) << said_bad;
}
#endif

}  // namespace
}  // namespace kiln
