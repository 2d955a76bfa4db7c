// Real models through the whole client path (issue 19, defect 14): every glTF, GLB, OBJ and FBX file of Debian's
// assimp-testmodels package (97 files, deliberately broken ones among them) is imported, uploaded, submitted to the
// real kilnd as a tiny lightmap bake (4² texels, 4 samples, 1 bounce) and followed to its end. Nothing may crash,
// nothing may send a frame protobuf cannot parse (libprotobuf logs an error when it serialises a string field that
// is not UTF-8, and kilnd drops the request), and every refusal, at import, at submit or in the bake, says why.
// The package is a CI dependency (deploy/setup.sh); without it the test is skipped, saying so.
// Issue 18: meshes without usable lightmap UVs get generated ones (generate_uvs AUTO, the default), so no model is
// refused for want of lightmap UVs alone; before, 38 of the 97 were ("nothing to bake: no instance has a lightmap").
// Measured: 66 bake (25 before), 29 are refused at import, 2 fail in the bake (every triangle degenerate or
// non-finite); on a loaded machine 2CylinderEngine.glb (34 meshes) can run out of the 30 s limit in its set-up.
#include <gtest/gtest.h>

#include <google/protobuf/stubs/logging.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <filesystem>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include "client/import/scene_import.h"
#include "client/lib/client.h"
#include "proto/kiln.pb.h"
#include "tests/integration/daemon_fixture.h"
#include "tests/integration/service_client.h"

namespace kiln {
namespace {

namespace fs = std::filesystem;
using test::Daemon;

const fs::path kModels = "/usr/share/assimp/models";

// The files kiln's importer is documented for, in a stable order.
std::vector<fs::path> models() {
  std::vector<fs::path> out;
  for (const auto& entry : fs::recursive_directory_iterator(kModels)) {
    if (!entry.is_regular_file()) continue;
    std::string ext = entry.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    if (ext == ".gltf" || ext == ".glb" || ext == ".obj" || ext == ".fbx") out.push_back(entry.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

// libprotobuf's errors in this process: it logs one for each string field that is not UTF-8 when it serialises.
std::atomic<int> protobuf_errors{0};
void count_protobuf_errors(google::protobuf::LogLevel level, const char* file, int line, const std::string& message) {
  if (level >= google::protobuf::LOGLEVEL_ERROR) {
    ++protobuf_errors;
    std::cerr << "libprotobuf " << file << ":" << line << ": " << message << "\n";
  }
}

v1::JobSpec tiny_bake(const client::ImportedScene& s, const std::string& name) {
  v1::JobSpec spec;
  spec.set_name(name);
  *spec.mutable_lightmap() = s.job;
  v1::LightmapJob& lm = *spec.mutable_lightmap();
  lm.set_resolution(4);
  lm.set_max_bounces(1);
  lm.set_preview(false);
  spec.mutable_quality()->set_samples(4);
  spec.mutable_quality()->set_time_limit_seconds(30);
  return spec;
}

TEST(AssimpModels, EveryModelImportsAndBakesOrIsRefusedSayingWhy) {
  if (!fs::is_directory(kModels)) {
    GTEST_SKIP() << "Debian's assimp-testmodels is not installed (" << kModels
                 << " is missing): `apt-get install assimp-testmodels` (deploy/setup.sh installs it) to run this test";
  }
  google::protobuf::SetLogHandler(count_protobuf_errors);
  const std::vector<fs::path> files = models();
  ASSERT_GE(files.size(), 90u) << "fewer models than the package's 97 under " << kModels;

  Daemon d;
  client::Client c = test::connect(d);
  std::map<std::string, std::vector<std::string>> outcomes;  // outcome → "model: detail"
  for (const fs::path& file : files) {
    const std::string model = fs::relative(file, kModels).string();
    SCOPED_TRACE(model);
    client::ImportedScene s;
    try {
      s = client::import_scene(file.string());
    } catch (const std::exception& e) {
      // "cannot import PATH: WHY": the file, and a reason after it.
      const std::string prefix = "cannot import " + file.string() + ": ";
      const std::string message = e.what();
      EXPECT_EQ(message.rfind(prefix, 0), 0u) << message;
      EXPECT_GT(message.size(), prefix.size() + 3) << message;
      outcomes["refused at import"].push_back(model + ": " + message.substr(std::min(prefix.size(), message.size())));
      continue;
    }
    for (const auto& [sha, bytes] : s.blobs) c.upload_blob(bytes);
    std::string id;
    try {
      id = c.submit(tiny_bake(s, "assimp-testmodels " + model)).job_id();
    } catch (const client::ServerError& e) {
      // RESOURCE_EXHAUSTED was kilnd's answer to a frame it could not parse ("cannot take the job now").
      EXPECT_NE(e.code(), v1::Error::RESOURCE_EXHAUSTED) << e.message();
      EXPECT_FALSE(e.message().empty());
      outcomes["refused at submit"].push_back(model + ": " + e.message());
      continue;
    }
    const v1::JobEvent final = c.watch(id);
    if (final.state() == v1::JOB_STATE_SUCCEEDED) {
      outcomes["baked"].push_back(model + ": " + std::to_string(s.job.instances_size()) + " instances, " +
                                  std::to_string(s.job.textures_size()) + " textures");
      continue;
    }
    EXPECT_EQ(final.state(), v1::JOB_STATE_FAILED);
    const v1::JobResult r = c.result(id);
    EXPECT_FALSE(r.error().message().empty());
    // Whatever else a model's meshes lack, lightmap UVs are generated for them: a mesh is left without lightmap UVs
    // only when none of its triangles can be baked (every one degenerate, non-finite or out of range; the importer
    // refuses a file without triangles), and then the refusal names that reason too.
    const std::string& why = r.error().message();
    if (why.find("no_lightmap_uv") != std::string::npos) {
      EXPECT_TRUE(why.find("degenerate_triangle") != std::string::npos ||
                  why.find("non_finite_vertex") != std::string::npos ||
                  why.find("index_out_of_range") != std::string::npos)
          << why;
    }
    // The first line of the reason (a scene check lists every problem after it).
    outcomes["failed in the bake"].push_back(model + ": " +
                                             r.error().message().substr(0, r.error().message().find('\n')));
  }
  google::protobuf::SetLogHandler(nullptr);
  EXPECT_EQ(protobuf_errors.load(), 0) << "libprotobuf logged errors: a string field was not UTF-8";
  // kilnd is still there and answers.
  EXPECT_NO_THROW(c.status());

  // The table the issue asks for, in the test's output.
  std::cout << files.size() << " models of assimp-testmodels (" << kModels.string() << "):\n";
  for (const auto& [outcome, list] : outcomes) {
    std::cout << "  " << outcome << ": " << list.size() << "\n";
    for (const std::string& line : list) std::cout << "    " << line << "\n";
  }
  // What issue 19 found broken: the two OBJ files with Latin-1 material names reach kilnd and are answered (one has
  // no UVs: it bakes with generated ones since issue 18), and the FBX whose texture is a TGA (RLE) bakes with it.
  const auto answered = [&](const std::string& name) {
    for (const char* outcome : {"baked", "failed in the bake"}) {
      for (const std::string& line : outcomes[outcome]) {
        if (line.rfind(name + ":", 0) == 0) return std::string(outcome);
      }
    }
    return std::string("not answered by kilnd");
  };
  EXPECT_EQ(answered("OBJ/regr01.obj"), "baked");
  EXPECT_EQ(answered("OBJ/box_mat_with_spaces.obj"), "baked");
  EXPECT_EQ(answered("FBX/box_orphant_embedded_texture.fbx"), "baked");
}

// The client library itself refuses to send a job with a string that is not UTF-8, naming the field, so that no
// caller of it (an importer of its own, a pipeline) sends kilnd a frame it cannot parse.
TEST(AssimpModels, TheClientRefusesToSendStringsThatAreNotUtf8) {
  Daemon d;
  client::Client c = test::connect(d);
  v1::JobSpec spec;
  spec.mutable_material()->mutable_ggx()->set_alpha(0.5);
  spec.set_name("Mat\xe9riau");
  try {
    c.submit(spec);
    ADD_FAILURE() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()).rfind("job.name: not valid UTF-8", 0), 0u) << e.what();
  }
  spec.set_name("ok");
  spec.clear_material();
  v1::SceneMaterial* m = spec.mutable_lightmap()->add_materials();
  m->set_name("white");
  spec.mutable_lightmap()->add_materials()->set_name("caf\xe9");
  try {
    c.submit(spec);
    ADD_FAILURE() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()).rfind("job.lightmap.materials[1].name: not valid UTF-8", 0), 0u) << e.what();
  }
  EXPECT_NO_THROW(c.status());  // nothing was sent: the connection is as it was
}

}  // namespace
}  // namespace kiln
