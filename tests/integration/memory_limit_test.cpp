// kilnd's memory limit and its stops against the real daemon: a job whose memory estimate exceeds --memory-limit is
// refused at submit naming the field that drives it; two jobs that fit one at a time but not together run one after
// the other; a big lightmap's time limit, a cancel and a SIGTERM all end it within a bounded time while it is still
// in its set-up (rasterization and leak probes of 1024² texels take tens of seconds on two cores).
#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "bakers/lightmap/memory_estimate.h"
#include "bakers/volume/vdb_file.h"
#include "client/lib/client.h"
#include "proto/kiln.pb.h"
#include "tests/integration/daemon_fixture.h"
#include "tests/integration/service_client.h"

namespace kiln {
namespace {

using Clock = std::chrono::steady_clock;
using client::Client;
using test::connect;
using test::Daemon;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// A 2 m quad facing +Y with lightmap UVs over [0, 1]², in the kiln mesh layout (proto/kiln.proto).
std::string quad_blob() {
  std::string b = "KILNMSH1";
  auto u32 = [&](uint32_t v) { b.append(reinterpret_cast<const char*>(&v), 4); };
  auto f32 = [&](float v) { b.append(reinterpret_cast<const char*>(&v), 4); };
  u32(4);
  u32(2);
  u32(4);  // lightmap UVs
  for (float p : {-1.f, 0.f, -1.f, 1.f, 0.f, -1.f, 1.f, 0.f, 1.f, -1.f, 0.f, 1.f}) f32(p);
  for (float t : {0.f, 0.f, 1.f, 0.f, 1.f, 1.f, 0.f, 1.f}) f32(t);
  for (uint32_t i : {0u, 2u, 1u, 0u, 3u, 2u}) u32(i);
  return b;
}

v1::JobSpec quad_job(const v1::Digest& mesh, int resolution, const std::string& name = "quad") {
  v1::JobSpec spec;
  spec.set_name(name);
  v1::LightmapJob* j = spec.mutable_lightmap();
  v1::Mesh* m = j->add_meshes();
  m->set_name("quad");
  *m->mutable_geometry() = mesh;
  j->mutable_environment()->mutable_constant()->set_r(1);
  j->set_resolution(resolution);
  spec.mutable_quality()->set_target_error(0.2);
  spec.mutable_quality()->set_samples(16);
  // Another name, another seed: jobs that differ, so that none is answered from the result cache.
  spec.mutable_quality()->set_seed(std::hash<std::string>{}(name));
  return spec;
}

// The daemon's estimate of quad_job, by the bakers' model with the shape the translation gives it (one lightmap,
// the blob's bound on triangles, the preview on, the outputs streamed), untiled.
uint64_t quad_estimate(int resolution, uint64_t blob_bytes) {
  lightmap::LightmapJobSize size;
  size.lightmap_texels = {static_cast<uint64_t>(resolution) * resolution};
  size.traced_triangles = (blob_bytes - 20) / 12;
  size.mesh_blob_bytes = blob_bytes;
  size.streamed = true;  // kilnd stores each output as the bake hands it over
  return lightmap::estimate_memory(size).total;
}

TEST(MemoryLimit, AJobThatCanNeverFitIsRefusedAtSubmitNamingTheField) {
  Daemon d({"--memory-limit", "256M"});
  Client c = connect(d);
  const v1::Digest mesh = c.upload_blob(quad_blob());
  try {
    c.submit(quad_job(mesh, 4096));
    ADD_FAILURE() << "a lightmap of 4096² texels fit in 256 MiB";
  } catch (const client::ServerError& e) {
    EXPECT_EQ(e.code(), v1::Error::RESOURCE_EXHAUSTED) << e.message();
    EXPECT_EQ(e.field(), "job.lightmap.resolution") << e.message();
    EXPECT_NE(e.message().find("--memory-limit"), std::string::npos) << e.message();
  }
  // A lightmap's own resolution, when it is the largest, is the field named.
  v1::JobSpec own = quad_job(mesh, 64);
  v1::LightmapSettings* s = own.mutable_lightmap()->add_lightmaps();
  s->set_name("quad");
  s->set_resolution(4096);
  try {
    c.submit(own);
    ADD_FAILURE() << "a lightmap of 4096² texels fit in 256 MiB";
  } catch (const client::ServerError& e) {
    EXPECT_EQ(e.field(), "job.lightmap.lightmaps[0].resolution") << e.message();
  }
  // A job that fits is taken and bakes.
  const v1::SubmitReply ok = c.submit(quad_job(mesh, 16));
  EXPECT_EQ(c.watch(ok.job_id()).state(), v1::JOB_STATE_SUCCEEDED);
}

// A VDB medium over the quad whose grids alone exceed a limit the rest of the job fits in many times over: refused at
// submit naming the medium's file, and taken and baked under an ample limit.
TEST(MemoryLimit, AJobWithALargeVdbMediumIsRefusedAtSubmitNamingItsFile) {
  // 192³ voxels of density 0.1 over 2 m: 13,824 leaves, about 34 MB of OpenVDB's trees (vdb_medium_memory_test.cpp).
  const int n = 192;
  const std::vector<uint8_t> vdb = volume::write_vdb({volume::make_vdb_grid(
      "density", n, n, n, std::vector<float>(static_cast<size_t>(n) * n * n, 0.1f), 2.0 / n, {-1, 0, -1})});
  const std::string blob(vdb.begin(), vdb.end());
  const uint64_t without = quad_estimate(16, quad_blob().size());
  const uint64_t medium = lightmap::vdb_medium_size(vdb, "density", "").tree_bytes;
  ASSERT_GT(medium, 4 * without);
  auto job = [&](Client& c) {
    v1::JobSpec spec = quad_job(c.upload_blob(quad_blob()), 16, "haze");
    v1::Medium* m = spec.mutable_lightmap()->add_media();
    *m->mutable_vdb()->mutable_file() = c.upload_blob(blob);
    m->mutable_sigma_s()->set_r(0.5);
    m->mutable_sigma_s()->set_g(0.5);
    m->mutable_sigma_s()->set_b(0.5);
    return spec;
  };
  {
    Daemon d({"--memory-limit", std::to_string(2 * without)});
    Client c = connect(d);
    try {
      c.submit(job(c));
      ADD_FAILURE() << "a job with " << medium << " bytes of VDB trees fit in " << 2 * without;
    } catch (const client::ServerError& e) {
      EXPECT_EQ(e.code(), v1::Error::RESOURCE_EXHAUSTED) << e.message();
      EXPECT_EQ(e.field(), "job.lightmap.media[0].vdb.file") << e.message();
      EXPECT_NE(e.message().find("1 VDB medium ("), std::string::npos) << e.message();
    }
  }
  Daemon d({"--memory-limit", "1G"});
  Client c = connect(d);
  const v1::SubmitReply ok = c.submit(job(c));
  EXPECT_EQ(c.watch(ok.job_id()).state(), v1::JOB_STATE_SUCCEEDED);
  // A file the structure walk refuses is refused at submit, on its field, with the walk's message.
  v1::JobSpec cut = job(c);
  *cut.mutable_lightmap()->mutable_media(0)->mutable_vdb()->mutable_file() = c.upload_blob(blob.substr(0, 1000));
  try {
    c.submit(cut);
    ADD_FAILURE() << "a VDB file cut short was taken";
  } catch (const client::ServerError& e) {
    EXPECT_EQ(e.code(), v1::Error::INVALID_ARGUMENT) << e.message();
    EXPECT_EQ(e.field(), "job.lightmap.media[0].vdb.file") << e.message();
  }
}

TEST(MemoryLimit, TwoJobsThatDoNotFitTogetherRunOneAfterTheOther) {
  const std::string blob = quad_blob();
  const uint64_t one = quad_estimate(256, blob.size());
  // Room for one, not for two (the estimates are equal).
  Daemon d({"--workers", "2", "--memory-limit", std::to_string(one + one / 2)});
  Client c = connect(d);
  const v1::Digest mesh = c.upload_blob(blob);
  const v1::SubmitReply a = c.submit(quad_job(mesh, 256, "first"));
  const v1::SubmitReply b = c.submit(quad_job(mesh, 256, "second"));
  bool waited = false;
  EXPECT_EQ(
      c.watch(b.job_id(),
              [&](const v1::JobEvent& e) { waited |= e.message().find("waiting for memory") != std::string::npos; })
          .state(),
      v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(c.watch(a.job_id()).state(), v1::JOB_STATE_SUCCEEDED);
  // In the log, the first job ended before the second began.
  const std::string log = d.log();
  const size_t a_done = log.find("job " + a.job_id() + ": succeeded");
  const size_t b_runs = log.find("job " + b.job_id() + ": running");
  ASSERT_NE(a_done, std::string::npos) << log;
  ASSERT_NE(b_runs, std::string::npos) << log;
  EXPECT_LT(a_done, b_runs) << log;
  EXPECT_NE(log.find("job " + b.job_id() + ": waiting for memory"), std::string::npos) << log;
  (void)waited;  // the watch may attach after the waiting event was replaced by "running"; the log is the record

  // With room for both, neither waits.
  Daemon roomy({"--workers", "2", "--memory-limit", std::to_string(3 * one)});
  Client r = connect(roomy);
  const v1::Digest mesh2 = r.upload_blob(blob);
  const v1::SubmitReply x = r.submit(quad_job(mesh2, 256, "x"));
  const v1::SubmitReply y = r.submit(quad_job(mesh2, 256, "y"));
  r.watch(x.job_id());
  r.watch(y.job_id());
  EXPECT_EQ(roomy.log().find("waiting for memory"), std::string::npos) << roomy.log();
}

// The job's state once it left QUEUED: waits for the first event past it.
void wait_running(Client& c, const std::string& id) {
  const Clock::time_point t0 = Clock::now();
  while (seconds_since(t0) < 30) {
    const v1::JobList list = c.list_jobs(10);
    for (const v1::JobSummary& j : list.jobs()) {
      if (j.job_id() == id && j.state() != v1::JOB_STATE_QUEUED) return;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  FAIL() << "job " << id << " did not start within 30 s";
}

TEST(MemoryLimit, ABigLightmapsTimeLimitEndsItDuringTheSetUp) {
  Daemon d;
  Client c = connect(d);
  const v1::Digest mesh = c.upload_blob(quad_blob());
  v1::JobSpec spec = quad_job(mesh, 1024);
  // A limit the set-up of a 1024² lightmap cannot meet on any machine (rasterizing its million texels alone takes
  // far longer), so that the limit ends it there, not in the passes.
  spec.mutable_quality()->set_time_limit_seconds(0.01);
  const Clock::time_point t0 = Clock::now();
  const v1::SubmitReply reply = c.submit(spec);
  EXPECT_EQ(c.watch(reply.job_id()).state(), v1::JOB_STATE_FAILED);
  const double seconds = seconds_since(t0);
  const v1::JobResult r = c.result(reply.job_id());
  EXPECT_EQ(r.error().code(), v1::Error::INVALID_ARGUMENT) << r.error().message();
  EXPECT_EQ(r.error().field(), "job.quality.time_limit_seconds") << r.error().message();
  // The limit, the mesh read and the translation before it (milliseconds), and the stop's poll: 3 s is generous.
  EXPECT_LT(seconds, 3.0) << r.error().message();
  std::printf("1024² lightmap, time limit 0.01 s: failed after %.2f s: %s\n", seconds, r.error().message().c_str());
}

TEST(MemoryLimit, ACancelDuringTheSetUpEndsTheJobWithinASecond) {
  Daemon d;
  Client c = connect(d);
  const v1::Digest mesh = c.upload_blob(quad_blob());
  const v1::SubmitReply reply = c.submit(quad_job(mesh, 1024));
  wait_running(c, reply.job_id());
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // into the set-up
  const Clock::time_point t0 = Clock::now();
  c.cancel(reply.job_id());
  EXPECT_EQ(c.watch(reply.job_id()).state(), v1::JOB_STATE_CANCELLED);
  const double seconds = seconds_since(t0);
  EXPECT_LT(seconds, 1.0);
  std::printf("1024² lightmap cancelled in its set-up: ended %.3f s after the cancel\n", seconds);
}

TEST(MemoryLimit, SigtermDuringTheSetUpExitsWithinItsGrace) {
  Daemon d({"--shutdown-grace", "1"});
  Client c = connect(d);
  const v1::Digest mesh = c.upload_blob(quad_blob());
  const v1::SubmitReply reply = c.submit(quad_job(mesh, 1024));
  wait_running(c, reply.job_id());
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const Clock::time_point t0 = Clock::now();
  EXPECT_EQ(d.terminate(), 0);
  const double seconds = seconds_since(t0);
  // The grace (1 s), then the bake's stop at its next poll (a fraction of a second; 0.4 to 1.1 s measured, the most
  // with the whole suite running beside it), bounded by the shutdown's 2 s last resort: 3.5 s leaves 0.5 s for the
  // exit itself on a loaded machine.
  EXPECT_LT(seconds, 3.5) << d.log();
  EXPECT_NE(d.log().find("job " + reply.job_id() + ": interrupted by the shutdown"), std::string::npos) << d.log();
  std::printf("SIGTERM with a 1 s grace during a 1024² set-up: exited after %.2f s\n", seconds);
}

}  // namespace
}  // namespace kiln
