// The lightmap job end to end against the real kilnd: `kiln bake lightmap` on the project's generated Cornell box
// (small and fast: 16² texels per lightmap, target error 0.1) writes valid outputs; the same submit again is a cache
// hit with the same output digests, and with --denoise another job that adds the denoised lightmaps; a corrupt mesh
// blob fails the job naming the mesh's field, a bad field is refused at submit naming its path, and the daemon goes
// on serving.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <string>

#include <nlohmann/json.hpp>

#include "bakers/image/exr.h"
#include "client/lib/client.h"
#include "proto/digest.h"
#include "proto/kiln.pb.h"
#include "tests/integration/daemon_fixture.h"
#include "tests/integration/kiln_cli_run.h"
#include "tests/integration/service_client.h"
#include "tests/support/run_command.h"

namespace kiln {
namespace {

namespace fs = std::filesystem;
using client::Client;
using test::connect;
using test::Daemon;
using test::read;

fs::path source_dir() { return fs::path(KILN_SOURCE_DIR); }

#ifdef KILN_BIN
using test::CliRun;
using test::kiln;

std::string job_id(const std::string& said) {
  std::smatch m;
  if (!std::regex_search(said, m, std::regex("submitted job ([0-9a-f]+)"))) return "";
  return m[1];
}

TEST(LightmapService, KilnBakeLightmapWritesValidOutputsAndTheSecondRunIsACacheHit) {
  Daemon d;
  const fs::path scene = d.dir() / "cornell_box.gltf", out = d.dir() / "out", again = d.dir() / "again";
  const std::string gen = "/usr/bin/python3 " + (source_dir() / "client/examples/scenes/cornell_box.py").string() +
                          " " + scene.string() + " > /dev/null";
  ASSERT_EQ(std::system(gen.c_str()), 0) << gen;
  const std::string args = "bake lightmap " + scene.string() + " --resolution 16 --target-error 0.1 --out ";
  const CliRun first = kiln(d, args + out.string());
  ASSERT_EQ(first.status, 0) << first.said;
  EXPECT_NE(first.said.find("8 meshes"), std::string::npos) << "the import summary is printed: " << first.said;

  for (const char* name :
       {"floor", "ceiling", "back_wall", "left_wall", "right_wall", "short_block", "tall_block", "light"}) {
    const std::string n = name;
    const image::FloatImage irradiance = image::decode_exr(read(out / (n + "_irradiance.exr")));
    const image::FloatImage validity = image::decode_exr(read(out / (n + "_validity.exr")));
    const image::FloatImage error = image::decode_exr(read(out / (n + "_error.exr")));
    EXPECT_TRUE(fs::exists(out / (n + "_preview.png"))) << n;
    EXPECT_EQ(irradiance.width, 16) << n;
    EXPECT_EQ(irradiance.height, 16) << n;
    EXPECT_GE(irradiance.channels, 3) << n;
    for (float v : irradiance.pixels) ASSERT_TRUE(std::isfinite(v) && v >= 0) << n << ": " << v;
    for (float v : error.pixels) ASSERT_TRUE(std::isfinite(v)) << n << ": " << v;
    int valid = 0;
    for (float v : validity.pixels) {
      ASSERT_TRUE(v == 0.0f || v == 1.0f) << n << ": validity " << v;
      valid += v == 1.0f;
    }
    EXPECT_GT(valid, 0) << n << ": no valid texel";
  }
  // The room is lit by its emissive patch: the floor under it receives light.
  const image::FloatImage floor = image::decode_exr(read(out / "floor_irradiance.exr"));
  double sum = 0;
  for (float v : floor.pixels) sum += v;
  EXPECT_GT(sum, 0);
  const std::string report = read(out / "report.json");
  EXPECT_NE(report.find("\"plan\""), std::string::npos);
  EXPECT_NE(report.find("\"curve\""), std::string::npos);

  // The same scene again: answered from the result cache, with the same outputs.
  const CliRun second = kiln(d, args + again.string());
  ASSERT_EQ(second.status, 0) << second.said;
  EXPECT_NE(second.said.find("cache hit"), std::string::npos) << second.said;
  Client c = connect(d);
  const v1::JobResult a = c.result(job_id(first.said)), b = c.result(job_id(second.said));
  EXPECT_FALSE(a.report().cache_hit());
  EXPECT_TRUE(b.report().cache_hit());
  EXPECT_GT(a.report().rays(), a.report().samples());  // every sample traces at least one ray
  EXPECT_FALSE(a.report().plan().empty());
  ASSERT_EQ(a.outputs_size(), b.outputs_size());
  for (int i = 0; i < a.outputs_size(); ++i) {
    EXPECT_EQ(a.outputs(i).digest().sha256(), b.outputs(i).digest().sha256()) << a.outputs(i).name();
    EXPECT_FALSE(a.outputs(i).description().empty()) << a.outputs(i).name();
  }
  EXPECT_EQ(read(out / "floor_irradiance.exr"), read(again / "floor_irradiance.exr"));

  // --denoise reaches the baker as another job (no cache hit on the raw one): the same raw lightmaps, and a denoised
  // one beside each, which the job without the flag did not write.
  const fs::path denoised = d.dir() / "denoised";
  const CliRun third = kiln(d, args + denoised.string() + " --denoise");
  ASSERT_EQ(third.status, 0) << third.said;
  EXPECT_EQ(third.said.find("cache hit"), std::string::npos) << third.said;
  for (const char* name : {"floor", "tall_block", "light"}) {
    const std::string n = name;
    EXPECT_FALSE(fs::exists(out / (n + "_irradiance_denoised.exr"))) << n;
    EXPECT_EQ(read(denoised / (n + "_irradiance.exr")), read(out / (n + "_irradiance.exr"))) << n;
    const image::FloatImage d_img = image::decode_exr(read(denoised / (n + "_irradiance_denoised.exr")));
    EXPECT_EQ(d_img.width, 16) << n;
    for (float v : d_img.pixels) ASSERT_TRUE(std::isfinite(v) && v >= 0) << n << ": " << v;
  }
  EXPECT_NE(read(denoised / "report.json").find("\"denoised\": true"), std::string::npos);
}

// A glTF quad (mesh "quad", lightmap UVs in TEXCOORD_0) placed by two nodes named "Post/A" (the name a file may give
// its nodes: not a file name) and lit by a constant sky through the CLI's --env-constant.
fs::path quad_placed_twice(const fs::path& dir) {
  const float positions[12] = {0, 0, 0, 1, 0, 0, 1, 0, -1, 0, 0, -1};
  const float uvs[8] = {0, 0, 1, 0, 1, 1, 0, 1};
  const uint32_t indices[6] = {0, 1, 2, 0, 2, 3};
  std::string bin(104, '\0');
  std::memcpy(bin.data(), positions, 48);
  std::memcpy(bin.data() + 48, uvs, 32);
  std::memcpy(bin.data() + 80, indices, 24);
  std::ofstream(dir / "twice.bin", std::ios::binary) << bin;
  std::ofstream(dir / "twice.gltf") << R"({"asset": {"version": "2.0"}, "buffers": [{"uri": "twice.bin", )"
                                       R"("byteLength": 104}], "bufferViews": [{"buffer": 0, "byteLength": 48}, )"
                                       R"({"buffer": 0, "byteOffset": 48, "byteLength": 32}, {"buffer": 0, )"
                                       R"("byteOffset": 80, "byteLength": 24}], "accessors": [{"bufferView": 0, )"
                                       R"("componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, -1], )"
                                       R"("max": [1, 0, 0]}, {"bufferView": 1, "componentType": 5126, "count": 4, )"
                                       R"("type": "VEC2"}, {"bufferView": 2, "componentType": 5125, "count": 6, )"
                                       R"("type": "SCALAR"}], "meshes": [{"name": "quad", "primitives": [{)"
                                       R"("attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2}]}], )"
                                       R"("nodes": [{"name": "Post/A", "mesh": 0}, {"name": "Post/A", "mesh": 0, )"
                                       R"("translation": [3, 0, 0]}], "scenes": [{"nodes": [0, 1]}], "scene": 0})";
  return dir / "twice.gltf";
}

// A mesh placed by two nodes bakes into a lightmap per placement whose files have plain names, and the report maps
// each lightmap's name in the job to the stem of its files (the client refused every output when the name held '/').
TEST(LightmapService, AMeshPlacedTwiceBakesIntoTwoLightmapsWithPlainFileNames) {
  Daemon d;
  const fs::path scene = quad_placed_twice(d.dir()), out = d.dir() / "out";
  const CliRun run = kiln(d, "bake lightmap " + scene.string() +
                                 " --resolution 8 --target-error 0.2 --env-constant 1 --out " + out.string());
  ASSERT_EQ(run.status, 0) << run.said;
  for (const char* stem : {"quad@Post_A", "quad@Post_A#1"}) {
    const std::string n = stem;
    ASSERT_TRUE(fs::exists(out / (n + "_irradiance.exr"))) << n << "\n" << run.said;
    const image::FloatImage e = image::decode_exr(read(out / (n + "_irradiance.exr")));
    double sum = 0;
    for (float v : e.pixels) sum += v;
    EXPECT_GT(sum, 0) << n << ": the sky lights each placement";
  }
  const std::string report = read(out / "report.json");
  EXPECT_NE(report.find(R"("input_name": "quad@Post/A")"), std::string::npos) << report;
  EXPECT_NE(report.find(R"("input_name": "quad@Post/A#1")"), std::string::npos) << report;
  EXPECT_NE(report.find("renamed_lightmap"), std::string::npos) << report;
}

// --texel-density: the Cornell box packed into atlas pages; lightmaps.json and every page's images come back, and
// each of the eight instances has a page, a scale and an offset.
TEST(LightmapService, TexelDensityBakesAtlasPagesWithAManifest) {
  Daemon d;
  const fs::path scene = d.dir() / "cornell_box.gltf", out = d.dir() / "out";
  const std::string gen = "/usr/bin/python3 " + (source_dir() / "client/examples/scenes/cornell_box.py").string() +
                          " " + scene.string() + " > /dev/null";
  ASSERT_EQ(std::system(gen.c_str()), 0) << gen;
  const CliRun run = kiln(d, "bake lightmap " + scene.string() +
                                 " --texel-density 8 --page-size 64 --max-pages 4 --target-error 0.2 --out " +
                                 out.string());
  ASSERT_EQ(run.status, 0) << run.said;
  const nlohmann::json manifest = nlohmann::json::parse(read(out / "lightmaps.json"));
  ASSERT_EQ(manifest["instances"].size(), 8u) << manifest.dump(1);
  std::set<std::string> pages;
  for (const nlohmann::json& page : manifest["pages"]) {
    const std::string name = page["name"];
    pages.insert(name);
    // Each page is page_size at most, shrunk to its charts in steps of 4 texels.
    const int size = page["size"];
    EXPECT_LE(size, 64);
    EXPECT_EQ(size % 4, 0);
    const image::FloatImage irradiance = image::decode_exr(read(out / (name + "_irradiance.exr")));
    EXPECT_EQ(irradiance.width, size) << name;
    for (const char* kind : {"_validity.exr", "_error.exr", "_preview.png"}) {
      EXPECT_TRUE(fs::exists(out / (name + kind))) << name << kind;
    }
    for (const nlohmann::json& f : page["files"]) EXPECT_TRUE(fs::exists(out / f.get<std::string>())) << f;
  }
  EXPECT_GE(pages.size(), 1u);
  EXPECT_LE(pages.size(), 4u);
  for (const nlohmann::json& e : manifest["instances"]) {
    ASSERT_TRUE(e["page"].is_string()) << e.dump();
    EXPECT_TRUE(pages.count(e["page"].get<std::string>()));
    EXPECT_GT(e["scale"][0].get<double>(), 0);
    EXPECT_GT(e["texel_density"].get<double>(), 0);
  }
  EXPECT_FALSE(fs::exists(out / "floor_irradiance.exr")) << "no per-mesh lightmaps when packing";
  EXPECT_NE(read(out / "report.json").find("\"atlas\""), std::string::npos);
}
#endif

// A small job through the client library: one quad under a constant sky, with the given mesh blob.
v1::JobSpec quad_job(const v1::Digest& mesh) {
  v1::JobSpec spec;
  v1::LightmapJob* j = spec.mutable_lightmap();
  v1::Mesh* m = j->add_meshes();
  m->set_name("quad");
  *m->mutable_geometry() = mesh;
  j->mutable_environment()->mutable_constant()->set_r(1);
  j->set_resolution(8);
  spec.mutable_quality()->set_target_error(0.2);
  return spec;
}

TEST(LightmapService, CorruptMeshBlobsAndBadFieldsAreClearErrorsAndTheDaemonGoesOn) {
  Daemon d;
  Client c = connect(d);
  // Right magic, wrong size: accepted at submit (blobs are decoded by the worker), failed naming the mesh.
  // Header: 1 vertex, 0 triangles, no flags (needs 12 bytes of position), then 4 bytes.
  std::string bytes = "KILNMSH1";
  bytes += std::string("\x01\0\0\0", 4) + std::string(8, '\0') + "junk";
  const v1::Digest corrupt = c.upload_blob(bytes);
  const v1::SubmitReply reply = c.submit(quad_job(corrupt));
  const v1::JobEvent final = c.watch(reply.job_id());
  EXPECT_EQ(final.state(), v1::JOB_STATE_FAILED);
  const v1::JobResult r = c.result(reply.job_id());
  EXPECT_EQ(r.error().code(), v1::Error::INVALID_ARGUMENT) << r.error().message();
  EXPECT_EQ(r.error().field(), "job.lightmap.meshes[0].geometry") << r.error().message();
  EXPECT_NE(r.error().message().find("header"), std::string::npos) << r.error().message();

  // A field out of range: refused at submit with its path.
  v1::JobSpec bad = quad_job(corrupt);
  bad.mutable_lightmap()->set_resolution(3);
  try {
    c.submit(bad);
    ADD_FAILURE() << "the server took a lightmap of 3 texels";
  } catch (const client::ServerError& e) {
    EXPECT_EQ(e.code(), v1::Error::INVALID_ARGUMENT);
    EXPECT_EQ(e.field(), "job.lightmap.resolution") << e.message();
  }
  // A mesh the server never received: refused at submit, naming the field.
  v1::Digest missing;
  missing.set_sha256(std::string(64, 'a'));
  missing.set_size(100);
  try {
    c.submit(quad_job(missing));
    ADD_FAILURE() << "the server took a job whose mesh it does not hold";
  } catch (const client::ServerError& e) {
    EXPECT_EQ(e.field(), "job.lightmap.meshes[0].geometry") << e.message();
  }
  // Still serving: it lists lightmap jobs among its types and reports its status.
  const v1::ServerStatus status = c.status();
  EXPECT_GE(status.jobs_failed(), 1u);
  EXPECT_TRUE(test::serves_job_type(d, "lightmap"));
}

}  // namespace
}  // namespace kiln
