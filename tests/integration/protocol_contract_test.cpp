// proto/kiln.proto's contract, request by request: every error code the file lists for a request is what the real
// kilnd answers, with the field path it documents (paths start inside the request's body, without its name); a
// GetResult of a job that has not ended is answered with its state and nothing else; a bad lobe of a layered material
// job is named by its path under "job.material.layered"; HelloReply's limits carry the deadlines and the memory limit.
#include <gtest/gtest.h>

#include <map>
#include <string>
#include <vector>

#include "bakers/image/exr.h"
#include "proto/digest.h"
#include "proto/kiln.pb.h"
#include "tests/integration/daemon_fixture.h"
#include "tests/integration/raw_connection.h"
#include "tests/integration/service_client.h"

namespace kiln {
namespace {

using test::Daemon;
using test::RawConnection;

// A connection that said Hello, for raw requests; ids count up from 1.
class Session {
 public:
  explicit Session(const Daemon& d) : c_(test::port_of(d.tcp())) {
    v1::Request r;
    r.mutable_hello()->set_protocol_version(1);
    r.mutable_hello()->set_token(d.token());
    hello_ = ask(r);
  }
  v1::Response ask(v1::Request r) {
    r.set_id(++id_);
    v1::Response resp = c_.call(r);
    EXPECT_EQ(resp.id(), r.id());
    return resp;
  }
  const v1::Response& hello() const { return hello_; }

 private:
  RawConnection c_;
  uint64_t id_ = 0;
  v1::Response hello_;
};

// The error a response carries, as "CODE field".
std::string error_of(const v1::Response& r) {
  if (!r.has_error()) return "no error";
  return v1::Error::Code_Name(r.error().code()) + " " + r.error().field();
}

const std::string kHex = std::string(64, 'a');

v1::Digest digest(const std::string& sha, uint64_t size) {
  v1::Digest d;
  d.set_sha256(sha);
  d.set_size(size);
  return d;
}

TEST(ProtocolContract, HelloErrorsAndLimits) {
  Daemon d({"--frame-deadline", "7", "--idle-timeout", "9", "--memory-limit", "3G"});
  auto hello = [&](uint32_t version, const std::string& token) {
    RawConnection c(test::port_of(d.tcp()));
    v1::Request r;
    r.set_id(1);
    r.mutable_hello()->set_protocol_version(version);
    r.mutable_hello()->set_token(token);
    return error_of(c.call(r));
  };
  EXPECT_EQ(hello(2, d.token()), "VERSION_MISMATCH protocol_version");
  EXPECT_EQ(hello(1, std::string(300, 't')), "INVALID_ARGUMENT token");
  EXPECT_EQ(hello(1, "wrong"), "UNAUTHENTICATED token");
  {
    RawConnection c(test::port_of(d.tcp()));
    v1::Request r;
    r.set_id(1);
    r.mutable_status();
    EXPECT_EQ(error_of(c.call(r)), "UNAUTHENTICATED ");
  }
  Session s(d);
  ASSERT_FALSE(s.hello().has_error()) << s.hello().error().message();
  const v1::Limits& l = s.hello().hello().limits();
  EXPECT_EQ(l.frame_deadline_seconds(), 7);
  EXPECT_EQ(l.idle_timeout_seconds(), 9);
  EXPECT_EQ(l.memory_limit_bytes(), uint64_t{3} << 30);
  EXPECT_GT(l.heartbeat_seconds(), 0u);
  // A request with no body: INVALID_ARGUMENT naming "body", and the connection stays open.
  EXPECT_EQ(error_of(s.ask(v1::Request())), "INVALID_ARGUMENT body");
  v1::Request status;
  status.mutable_status();
  EXPECT_EQ(error_of(s.ask(status)), "no error");
}

TEST(ProtocolContract, BlobErrors) {
  Daemon d;
  Session s(d);
  const uint64_t max_blob = s.hello().hello().limits().max_blob_bytes();
  const uint64_t max_chunk = s.hello().hello().limits().max_chunk_bytes();
  v1::Request q;
  for (int i = 0; i < 1025; ++i) *q.mutable_blob_query()->add_digests() = digest(kHex, 1);
  EXPECT_EQ(error_of(s.ask(q)), "INVALID_ARGUMENT digests");
  q.mutable_blob_query()->clear_digests();
  *q.mutable_blob_query()->add_digests() = digest(kHex, 1);
  *q.mutable_blob_query()->add_digests() = digest("XYZ", 1);
  EXPECT_EQ(error_of(s.ask(q)), "INVALID_ARGUMENT digests[1].sha256");
  q.mutable_blob_query()->clear_digests();
  *q.mutable_blob_query()->add_digests() = digest(kHex, max_blob + 1);
  EXPECT_EQ(error_of(s.ask(q)), "RESOURCE_EXHAUSTED digests[0].size");

  const std::string bytes = "hello, kiln";
  const std::string sha = proto::sha256_hex(bytes);
  auto put = [&](const v1::Digest& dg, uint64_t offset, const std::string& data) {
    v1::Request r;
    *r.mutable_blob_put()->mutable_digest() = dg;
    r.mutable_blob_put()->set_offset(offset);
    r.mutable_blob_put()->set_data(data);
    return s.ask(r);
  };
  EXPECT_EQ(error_of(put(digest("nothex", 5), 0, "x")), "INVALID_ARGUMENT digest.sha256");
  EXPECT_EQ(error_of(put(digest(kHex, max_blob + 1), 0, "x")), "RESOURCE_EXHAUSTED digest.size");
  EXPECT_EQ(error_of(put(digest(kHex, 4 * max_chunk), 0, std::string(max_chunk + 1, 'x'))), "INVALID_ARGUMENT data");
  EXPECT_EQ(error_of(put(digest(sha, bytes.size()), 0, bytes + "!")), "INVALID_ARGUMENT data");
  EXPECT_EQ(error_of(put(digest(sha, bytes.size()), 3, "lo")), "FAILED_PRECONDITION offset");
  EXPECT_EQ(error_of(put(digest(sha, bytes.size()), 0, "HELLO, KILN")), "DATA_LOSS ");
  const v1::Response ok = put(digest(sha, bytes.size()), 0, bytes);
  EXPECT_EQ(error_of(ok), "no error");
  EXPECT_TRUE(ok.blob_put().complete());
  // A blob the server holds: complete at once, whatever the offset.
  EXPECT_TRUE(put(digest(sha, bytes.size()), 5, "").blob_put().complete());

  auto fetch = [&](const v1::Digest& dg, uint64_t offset, uint64_t length) {
    v1::Request r;
    *r.mutable_fetch()->mutable_digest() = dg;
    r.mutable_fetch()->set_offset(offset);
    r.mutable_fetch()->set_length(length);
    return s.ask(r);
  };
  EXPECT_EQ(error_of(fetch(digest("nothex", 5), 0, 0)), "INVALID_ARGUMENT digest.sha256");
  EXPECT_EQ(error_of(fetch(digest(sha, bytes.size()), bytes.size() + 1, 0)), "INVALID_ARGUMENT offset");
  EXPECT_EQ(error_of(fetch(digest(sha, bytes.size()), 0, max_chunk + 1)), "INVALID_ARGUMENT length");
  EXPECT_EQ(error_of(fetch(digest(kHex, max_blob + 1), 0, 0)), "RESOURCE_EXHAUSTED digest.size");
  EXPECT_EQ(error_of(fetch(digest(kHex, 3), 0, 0)), "NOT_FOUND digest");
  EXPECT_EQ(fetch(digest(sha, bytes.size()), 0, 0).fetch().data(), bytes);
}

TEST(ProtocolContract, JobRequestErrors) {
  Daemon d;
  Session s(d);
  auto submit = [&](const v1::JobSpec& job, int priority = 0, const std::string& key = {}) {
    v1::Request r;
    *r.mutable_submit()->mutable_job() = job;
    r.mutable_submit()->set_priority(priority);
    r.mutable_submit()->set_idempotency_key(key);
    return s.ask(r);
  };
  const v1::JobSpec ok = test::ggx_job(0.3);
  EXPECT_EQ(error_of(submit(ok, 101)), "INVALID_ARGUMENT priority");
  EXPECT_EQ(error_of(submit(ok, 0, std::string(129, 'k'))), "INVALID_ARGUMENT idempotency_key");
  EXPECT_EQ(error_of(submit(v1::JobSpec())), "INVALID_ARGUMENT job");
  v1::JobSpec layered;
  layered.mutable_material()->mutable_layered()->mutable_specular()->mutable_ggx()->set_alpha(2);
  EXPECT_EQ(error_of(submit(layered)), "INVALID_ARGUMENT job.material.layered.specular.ggx.alpha");
  EXPECT_EQ(error_of(submit(ok, 0, "key")), "no error");
  EXPECT_EQ(error_of(submit(test::ggx_job(0.4), 0, "key")), "INVALID_ARGUMENT ");

  for (const char* which : {"watch", "cancel", "get_result"}) {
    for (const auto& [id, expected] : {std::pair{std::string(), "INVALID_ARGUMENT job_id"},
                                       std::pair{std::string(65, 'j'), "INVALID_ARGUMENT job_id"},
                                       std::pair{std::string("nosuchjob"), "NOT_FOUND job_id"}}) {
      v1::Request r;
      const std::string w = which;
      if (w == "watch") r.mutable_watch()->set_job_id(id);
      if (w == "cancel") r.mutable_cancel()->set_job_id(id);
      if (w == "get_result") r.mutable_get_result()->set_job_id(id);
      EXPECT_EQ(error_of(s.ask(r)), expected) << which << " '" << id << "'";
    }
  }
  v1::Request list;
  list.mutable_list_jobs()->set_limit(1001);
  EXPECT_EQ(error_of(s.ask(list)), "INVALID_ARGUMENT limit");
  list.mutable_list_jobs()->set_limit(0);
  list.mutable_list_jobs()->set_state(static_cast<v1::JobState>(99));
  EXPECT_EQ(error_of(s.ask(list)), "INVALID_ARGUMENT state");
}

TEST(ProtocolContract, GetResultOfAJobThatHasNotEndedAnswersItsStateAlone) {
  Daemon d;
  client::Client c = test::connect(d);
  // Minutes of baking at 2^20 samples over 64 x 64 tables; a second one waits behind it in the queue.
  const std::string running = c.submit(test::ggx_job(0.3, uint64_t{1} << 20, 64)).job_id();
  const std::string queued = c.submit(test::ggx_job(0.5, uint64_t{1} << 20, 64)).job_id();
  for (const std::string& id : {running, queued}) {
    const v1::JobResult r = c.result(id);
    EXPECT_TRUE(r.state() == v1::JOB_STATE_QUEUED || r.state() == v1::JOB_STATE_RUNNING) << r.state();
    EXPECT_EQ(r.job_id(), id);
    EXPECT_EQ(r.outputs_size(), 0);
    EXPECT_FALSE(r.has_error());
    EXPECT_FALSE(r.has_report());
    EXPECT_GT(r.submitted_unix(), 0);
  }
  c.cancel(queued);
  c.cancel(running);
  EXPECT_EQ(c.watch(running).state(), v1::JOB_STATE_CANCELLED);
  const v1::JobResult cancelled = c.result(queued);
  EXPECT_EQ(cancelled.state(), v1::JOB_STATE_CANCELLED);
  EXPECT_FALSE(cancelled.has_error());
  EXPECT_EQ(cancelled.outputs_size(), 0);
}

// A mesh blob in the kiln mesh layout: a 2 m quad facing +Y (4 vertices), its two triangles plus `extra` index
// triples, with lightmap UVs when asked and, when given, a material index per triangle.
std::string mesh_blob(bool lightmap_uv, const std::vector<uint32_t>& extra, const std::vector<uint32_t>& materials) {
  std::string b = "KILNMSH1";
  auto u32 = [&](uint32_t v) { b.append(reinterpret_cast<const char*>(&v), 4); };
  auto f32 = [&](float v) { b.append(reinterpret_cast<const char*>(&v), 4); };
  const uint32_t triangles = 2 + static_cast<uint32_t>(extra.size() / 3);
  u32(4);
  u32(triangles);
  u32((lightmap_uv ? 4u : 0u) | (materials.empty() ? 0u : 8u));
  for (float p : {-1.f, 0.f, -1.f, 1.f, 0.f, -1.f, 1.f, 0.f, 1.f, -1.f, 0.f, 1.f}) f32(p);
  if (lightmap_uv) {
    for (float t : {0.f, 0.f, 1.f, 0.f, 1.f, 1.f, 0.f, 1.f}) f32(t);
  }
  for (uint32_t i : {0u, 2u, 1u, 0u, 3u, 2u}) u32(i);
  for (uint32_t i : extra) u32(i);
  for (uint32_t m : materials) u32(m);
  return b;
}

v1::JobSpec mesh_job(const v1::Digest& mesh) {
  v1::JobSpec spec;
  v1::LightmapJob* j = spec.mutable_lightmap();
  v1::Mesh* m = j->add_meshes();
  m->set_name("quad");
  *m->mutable_geometry() = mesh;
  v1::Color* sky = j->mutable_environment()->mutable_constant();
  sky->set_r(1);
  sky->set_g(1);
  sky->set_b(1);
  j->set_resolution(8);
  spec.mutable_quality()->set_target_error(0.2);
  return spec;
}

TEST(ProtocolContract, LightmapUvsAreRequiredAndBadMeshDataIsDroppedAndReported) {
  Daemon d;
  client::Client c = test::connect(d);
  // No lightmap UVs anywhere and none generated: nothing to bake, the job FAILS naming the lightmap job.
  v1::JobSpec without = mesh_job(c.upload_blob(mesh_blob(false, {}, {})));
  without.mutable_lightmap()->set_generate_uvs(v1::GENERATE_UVS_NEVER);
  const v1::SubmitReply none = c.submit(without);
  EXPECT_EQ(c.watch(none.job_id()).state(), v1::JOB_STATE_FAILED);
  const v1::JobResult failed = c.result(none.job_id());
  EXPECT_EQ(failed.error().code(), v1::Error::INVALID_ARGUMENT) << failed.error().message();
  EXPECT_EQ(failed.error().field(), "job.lightmap") << failed.error().message();
  EXPECT_NE(failed.error().message().find("nothing to bake"), std::string::npos) << failed.error().message();

  // A triangle with a vertex index out of range is dropped, a material index out of range uses material 0; the job
  // bakes what is left and reports both. The job has no materials: material 0 is the default, Lambert of albedo 0.8,
  // which the radiance output shows: an open plane under a uniform sky of 1 has E = π, so ρE/π = ρ (the bakers'
  // estimate of E is π up to rounding here, lightmap_bake_test; 1e-4 is float storage with room to spare).
  v1::JobSpec spec = mesh_job(c.upload_blob(mesh_blob(true, {0, 1, 99}, {0, 7, 0})));
  spec.mutable_lightmap()->set_radiance(true);
  const v1::SubmitReply bad = c.submit(spec);
  EXPECT_EQ(c.watch(bad.job_id()).state(), v1::JOB_STATE_SUCCEEDED);
  const v1::JobResult result = c.result(bad.job_id());
  const std::string& report = result.report().json();
  EXPECT_NE(report.find("index_out_of_range"), std::string::npos) << report;
  EXPECT_NE(report.find("material_out_of_range"), std::string::npos) << report;
  std::map<std::string, image::FloatImage> images;
  for (const v1::Output& o : result.outputs()) {
    if (o.name() == "quad_radiance.exr" || o.name() == "quad_validity.exr") {
      images[o.name()] = image::decode_exr(c.fetch(o.digest()));
    }
  }
  ASSERT_EQ(images.size(), 2u);
  const image::FloatImage& radiance = images["quad_radiance.exr"];
  const image::FloatImage& valid = images["quad_validity.exr"];
  int checked = 0;
  for (int y = 0; y < valid.height; ++y) {
    for (int x = 0; x < valid.width; ++x) {
      if (valid.at(x, y, 0) != 1.0f) continue;
      for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(radiance.at(x, y, ch), 0.8, 1e-4) << x << "," << y;
      ++checked;
    }
  }
  EXPECT_GT(checked, 0);
}

}  // namespace
}  // namespace kiln
