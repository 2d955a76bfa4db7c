// kilnd at start: what it recovers, what it cleans, and what it refuses (with a message saying why), each against
// the real daemon.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <thread>

#include "client/lib/client.h"
#include "proto/kiln.pb.h"
#include "tests/integration/daemon_fixture.h"

namespace kiln {
namespace {

using client::Client;
using test::Daemon;

Client connect(const Daemon& d) {
  Client c(d.tcp());
  c.hello(d.token());
  return c;
}

v1::JobSpec long_material_job() {
  v1::JobSpec spec;
  spec.set_name("bakes for minutes");  // 64 x 64 tables at 2^20 samples per entry
  spec.mutable_material()->mutable_ggx()->set_alpha(0.3);
  spec.mutable_material()->set_table_mu(64);
  spec.mutable_material()->set_table_roughness(64);
  spec.mutable_quality()->set_samples(1 << 20);
  return spec;
}

// The crash-loop guard is a setting: with --max-crash-restarts 1, one crash while the job runs fails it at the next
// start, and the failure names the setting so that an operator knows what stopped it and how to change it.
TEST(Startup, CrashLoopGuardIsASettingNamedInTheFailure) {
  std::filesystem::path dir;
  std::string id;
  {
    Daemon d;
    d.keep();
    dir = d.dir();
    Client c = connect(d);
    id = c.submit(long_material_job()).job_id();
    for (int i = 0; i < 500 && c.result(id).state() != v1::JOB_STATE_RUNNING; ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    ASSERT_EQ(c.result(id).state(), v1::JOB_STATE_RUNNING);
    d.kill9();
  }
  Daemon again({"--max-crash-restarts", "1"}, dir);
  Client c = connect(again);
  const v1::JobResult r = c.result(id);
  ASSERT_EQ(r.state(), v1::JOB_STATE_FAILED) << again.log();
  EXPECT_NE(r.error().message().find("max_crash_restarts = 1"), std::string::npos) << r.error().message();
  EXPECT_NE(r.error().message().find("--max-crash-restarts"), std::string::npos) << r.error().message();
  EXPECT_NE(again.log().find("not run again"), std::string::npos) << again.log();
}

}  // namespace
}  // namespace kiln
