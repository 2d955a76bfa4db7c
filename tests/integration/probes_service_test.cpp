// The light probes job end to end against the real kilnd: `kiln bake probes` on the project's generated Cornell box
// writes probes.vdb (read back without kiln's own structures: grids, metadata, one active voxel per placed probe),
// its preview and report; the same command again is a cache hit with the same file; `kiln bake lightmap --probes`
// bakes both in one job; bad probe settings and a missing mesh are refused at submit naming their fields.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>

#include <nlohmann/json.hpp>

#include "bakers/volume/probe_vdb.h"
#include "client/lib/client.h"
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

#ifdef KILN_BIN
using test::CliRun;
using test::kiln;

fs::path cornell_box(const Daemon& d) {
  const fs::path scene = d.dir() / "cornell_box.gltf";
  const std::string gen = "/usr/bin/python3 " +
                          (fs::path(KILN_SOURCE_DIR) / "client/examples/scenes/cornell_box.py").string() + " " +
                          scene.string() + " > /dev/null";
  EXPECT_EQ(std::system(gen.c_str()), 0) << gen;
  return scene;
}

volume::ProbeVdbContents probes_file(const fs::path& p) {
  const std::string bytes = read(p);
  return volume::read_probe_vdb({reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()});
}

TEST(ProbesService, KilnBakeProbesWritesAReadableVolumeAndTheSecondRunIsACacheHit) {
  Daemon d;
  const fs::path scene = cornell_box(d), out = d.dir() / "out", again = d.dir() / "again";
  const std::string args = "bake probes " + scene.string() + " --spacing 0.5 --target-error 0.2 --out ";
  const CliRun first = kiln(d, args + out.string());
  ASSERT_EQ(first.status, 0) << first.said;
  const volume::ProbeVdbContents c = probes_file(out / "probes.vdb");
  ASSERT_EQ(c.grids.size(), 29u);
  EXPECT_EQ(c.grids[0].name, "sh0_r");
  EXPECT_EQ(c.metadata.at("kiln:spacing"), "0.5");
  EXPECT_NE(c.metadata.at("kiln:units").find("W m^-2 sr^-1"), std::string::npos);
  const nlohmann::json report = nlohmann::json::parse(read(out / "report.json"));
  const nlohmann::json& counts = report["probes"]["counts"];
  EXPECT_EQ(counts["placed"].get<size_t>(), c.lattice.voxels.size());
  EXPECT_EQ(counts["placed"].get<size_t>(),
            counts["valid"].get<size_t>() + counts["invalid_inside_geometry"].get<size_t>());
  EXPECT_GT(counts["valid"].get<size_t>(), 0u);
  // The blocks are closed (their open bottom stands on the floor): the probes inside them see back faces.
  EXPECT_GT(counts["invalid_inside_geometry"].get<size_t>(), 0u) << report["probes"].dump(2);
  EXPECT_GT(counts["skipped_far_from_geometry"].get<size_t>(), 0u) << report["probes"].dump(2);
  EXPECT_TRUE(report["lightmaps"].empty());
  EXPECT_FALSE(read(out / "probes_preview.png").empty());
  // Every value finite; inside the box, which its ceiling light lights, every valid probe's DC term positive (outside
  // there is no environment: a probe that sees only the void beside the box is valid and black).
  size_t inside = 0;
  for (size_t p = 0; p < c.lattice.voxels.size(); ++p) {
    for (const auto& g : c.grids) EXPECT_TRUE(std::isfinite(g.values[p])) << g.name;
    const auto& v = c.lattice.voxels[p];
    const double x = c.lattice.origin.x + 0.5 * v[0], y = c.lattice.origin.y + 0.5 * v[1],
                 z = c.lattice.origin.z + 0.5 * v[2];
    if (std::abs(x) < 1 && y > 0 && y < 2 && std::abs(z) < 1 && c.grids[27].values[p] == 1.0f) {
      EXPECT_GT(c.grids[0].values[p], 0.0f) << "probe at " << x << ", " << y << ", " << z;
      ++inside;
    }
  }
  EXPECT_GT(inside, 0u);

  const CliRun second = kiln(d, args + again.string());
  ASSERT_EQ(second.status, 0) << second.said;
  EXPECT_EQ(read(out / "probes.vdb"), read(again / "probes.vdb")) << "a cache hit serves the stored file";
  EXPECT_NE(second.said.find("cache"), std::string::npos) << second.said;
}

TEST(ProbesService, KilnBakeLightmapWithProbesBakesBothInOneJob) {
  Daemon d;
  const fs::path scene = cornell_box(d), out = d.dir() / "out";
  const CliRun run =
      kiln(d, "bake lightmap " + scene.string() +
                  " --resolution 8 --target-error 0.3 --probes 0.5 --region -1,0,-1,1,2,1 --out " + out.string());
  ASSERT_EQ(run.status, 0) << run.said;
  EXPECT_TRUE(fs::exists(out / "floor_irradiance.exr"));
  const volume::ProbeVdbContents c = probes_file(out / "probes.vdb");
  for (const auto& v : c.lattice.voxels) {
    const double y = c.lattice.origin.y + c.lattice.voxel_size * v[1];
    EXPECT_GE(y, 0.0);  // inside the region given
    EXPECT_LE(y, 2.0);
  }
  EXPECT_EQ(c.lattice.voxels.size(), 4u * 4u * 4u);  // the 2 m box at 0.5: every cell within 1 m of a wall
}

TEST(ProbesService, ProbeFlagsOutOfRangeAreRefusedByTheClientNamingTheFlag) {
  Daemon d;
  const fs::path scene = cornell_box(d);
  const CliRun zero = kiln(d, "bake probes " + scene.string() + " --spacing 0 --out " + (d.dir() / "o").string());
  EXPECT_EQ(zero.status, 2) << zero.said;
  EXPECT_NE(zero.said.find("--spacing"), std::string::npos) << zero.said;
  const CliRun missing = kiln(d, "bake probes " + scene.string() + " --out " + (d.dir() / "o").string());
  EXPECT_EQ(missing.status, 2) << missing.said;
  EXPECT_NE(missing.said.find("--spacing"), std::string::npos) << missing.said;
}
#endif

// A probes job through the client library: one quad under a constant sky.
v1::JobSpec probes_job(const v1::Digest& mesh) {
  v1::JobSpec spec;
  v1::ProbesJob* p = spec.mutable_probes();
  v1::Mesh* m = p->mutable_scene()->add_meshes();
  m->set_name("quad");
  *m->mutable_geometry() = mesh;
  p->mutable_scene()->mutable_environment()->mutable_constant()->set_r(1);
  p->mutable_volume()->set_spacing(0.5);
  spec.mutable_quality()->set_target_error(0.2);
  return spec;
}

std::string refused_field(Client& c, const v1::JobSpec& spec) {
  try {
    c.submit(spec);
  } catch (const client::ServerError& e) {
    EXPECT_EQ(e.code(), v1::Error::INVALID_ARGUMENT) << e.message();
    return e.field();
  }
  return "(accepted)";
}

TEST(ProbesService, BadSettingsAndMissingBlobsAreRefusedNamingTheField) {
  Daemon d;
  Client c = connect(d);
  // A unit quad in the KILNMSH1 layout: 4 vertices, 2 triangles, no flags.
  std::string quad = "KILNMSH1";
  auto u32 = [&](uint32_t v) { quad.append(reinterpret_cast<const char*>(&v), 4); };
  auto f32 = [&](float v) { quad.append(reinterpret_cast<const char*>(&v), 4); };
  u32(4), u32(2), u32(0);
  for (float p : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 1.f, 0.f, -1.f, 0.f, 0.f, -1.f}) f32(p);
  for (uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) u32(i);
  const v1::Digest mesh = c.upload_blob(quad);

  const v1::SubmitReply reply = c.submit(probes_job(mesh));
  EXPECT_EQ(c.watch(reply.job_id()).state(), v1::JOB_STATE_SUCCEEDED) << c.result(reply.job_id()).error().message();
  bool has_vdb = false;
  const v1::JobResult result = c.result(reply.job_id());
  for (const auto& o : result.outputs()) has_vdb |= o.name() == "probes.vdb";
  EXPECT_TRUE(has_vdb);

  v1::JobSpec zero = probes_job(mesh);
  zero.mutable_probes()->mutable_volume()->set_spacing(0);
  EXPECT_EQ(refused_field(c, zero), "job.probes.volume.spacing");
  v1::JobSpec flat = probes_job(mesh);
  v1::MediumBox* box = flat.mutable_probes()->mutable_volume()->add_regions();
  box->mutable_lo()->set_y(1);
  box->mutable_hi()->set_x(1), box->mutable_hi()->set_y(1), box->mutable_hi()->set_z(1);
  EXPECT_EQ(refused_field(c, flat), "job.probes.volume.regions[0].hi");
  v1::JobSpec nan = probes_job(mesh);
  nan.mutable_probes()->mutable_volume()->set_max_distance(std::nan(""));
  EXPECT_EQ(refused_field(c, nan), "job.probes.volume.max_distance");
  v1::Digest missing;
  missing.set_sha256(std::string(64, 'a'));
  missing.set_size(100);
  EXPECT_EQ(refused_field(c, probes_job(missing)), "job.probes.scene.meshes[0].geometry");
  v1::JobSpec no_volume = probes_job(mesh);
  no_volume.mutable_probes()->clear_volume();
  EXPECT_EQ(refused_field(c, no_volume), "job.probes.volume");
  EXPECT_TRUE(test::serves_job_type(d, "probes"));
}

}  // namespace
}  // namespace kiln
