// kilnd at start: what it recovers, what it cleans, and what it refuses (with a message saying why), each against
// the real daemon.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <thread>
#include <utility>

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

// Runs kilnd with `args` (paths without spaces) until it exits, at most 20 s; its exit status and output.
std::pair<int, std::string> run_kilnd(const std::string& args) {
  const std::string command = "timeout 20 " + std::string(KILND_BIN) + " " + args + " 2>&1";
  FILE* p = ::popen(command.c_str(), "r");
  if (!p) return {-1, "popen failed"};
  std::string out;
  char buf[4096];
  while (std::fgets(buf, sizeof buf, p)) out += buf;
  const int status = ::pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

// A second kilnd given the Unix socket of a running one used to unlink it and bind its own, cutting the first off
// from its clients. Now it refuses to start, naming the process that listens, and the first is still reachable.
TEST(Startup, ASecondKilndDoesNotStealALiveUnixSocket) {
  Daemon d;
  const auto other_store = d.dir() / "other-store";
  const auto [status, out] = run_kilnd("--listen '' --socket " + (d.dir() / "kilnd.sock").string() + " --store " +
                                       other_store.string());
  EXPECT_EQ(status, 1) << out;
  EXPECT_NE(out.find("is listening on it"), std::string::npos) << out;
  EXPECT_NE(out.find("process " + std::to_string(d.pid())), std::string::npos) << out;
  Client c(d.unix_address());
  EXPECT_NO_THROW(c.hello(""));
  EXPECT_NO_THROW(c.status());
}

// A socket file nobody listens on (left by a kilnd that was killed) is removed and bound again.
TEST(Startup, AStaleUnixSocketIsReplaced) {
  std::filesystem::path dir;
  {
    Daemon d;
    d.keep();
    dir = d.dir();
    d.kill9();  // leaves kilnd.sock behind
  }
  ASSERT_TRUE(std::filesystem::is_socket(dir / "kilnd.sock"));
  Daemon again({}, dir);
  Client c(again.unix_address());
  EXPECT_NO_THROW(c.hello(""));
}

}  // namespace
}  // namespace kiln
