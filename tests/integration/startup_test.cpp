// kilnd at start: what it recovers, what it cleans, and what it refuses (with a message saying why), each against
// the real daemon.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <thread>
#include <utility>

#include "client/lib/client.h"
#include "proto/digest.h"
#include "proto/kiln.pb.h"
#include "tests/integration/daemon_fixture.h"
#include "tests/integration/raw_connection.h"
#include "tests/integration/service_client.h"
#include "tests/support/run_command.h"

namespace kiln {
namespace {

using client::Client;
using test::connect;
using test::Daemon;
using test::ggx_job;

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
    id = c.submit(ggx_job(0.3, 1 << 20, 64)).job_id();
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
  const test::CommandResult r = test::run_command("timeout 20 " + std::string(KILND_BIN) + " " + args + " 2>&1");
  return {r.status, r.output};
}

// A second kilnd given the Unix socket of a running one used to unlink it and bind its own, cutting the first off
// from its clients. Now it refuses to start, naming the process that listens, and the first is still reachable.
TEST(Startup, ASecondKilndDoesNotStealALiveUnixSocket) {
  Daemon d;
  const auto other_store = d.dir() / "other-store";
  const auto [status, out] =
      run_kilnd("--listen '' --socket " + (d.dir() / "kilnd.sock").string() + " --store " + other_store.string());
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

// Sends the first half of a 64 KiB blob and stops, as a client that gave up; returns the blob's digest.
v1::Digest upload_half(const Daemon& d) {
  std::string blob(64 << 10, '\0');
  for (size_t i = 0; i < blob.size(); ++i) blob[i] = static_cast<char>(i * 13 + 5);
  v1::Digest digest;
  digest.set_sha256(proto::sha256_hex(blob));
  digest.set_size(blob.size());
  test::RawConnection raw(test::port_of(d.tcp()));
  EXPECT_FALSE(raw.call(test::hello_request(1, d.token())).has_error());
  v1::Request put;
  put.set_id(2);
  *put.mutable_blob_put()->mutable_digest() = digest;
  put.mutable_blob_put()->set_data(blob.substr(0, blob.size() / 2));
  const v1::Response r = raw.call(put);
  EXPECT_EQ(r.blob_put().received(), blob.size() / 2) << r.error().message();
  return digest;
}

uint64_t received(const Daemon& d, const v1::Digest& digest) {
  Client c = connect(d);
  const v1::BlobQueryReply q = c.query_blobs({digest});
  return q.missing_size() == 1 ? q.missing(0).received() : digest.size();
}

size_t partial_files(const Daemon& d) {
  size_t n = 0;
  for (const auto& e : std::filesystem::directory_iterator(d.dir() / "store" / "partial")) n += e.is_regular_file();
  return n;
}

// The cleanup of abandoned uploads existed but was never called: 60 MB of partial uploads survived 8 restarts.
// With --partial-upload-max-age 1 the sweep (every second here) deletes a partial upload left alone for over 1 s.
TEST(Startup, AbandonedUploadsAreDeletedAfterTheirAge) {
  Daemon d({"--partial-upload-max-age", "1"});
  const v1::Digest digest = upload_half(d);
  bool gone = false;
  for (int i = 0; i < 100 && !gone; ++i) {  // up to 10 s: the age (1 s) plus a sweep period (1 s), generously
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    gone = partial_files(d) == 0;
  }
  EXPECT_TRUE(gone) << d.log();
  EXPECT_EQ(received(d, digest), 0u);  // a client coming back starts over
  EXPECT_NE(d.log().find("partial upload(s) untouched"), std::string::npos) << d.log();
}

// At start, partial uploads older than the age are deleted before anything else; younger ones stay to resume.
TEST(Startup, AbandonedUploadsAreDeletedAtStart) {
  std::filesystem::path dir;
  v1::Digest old_digest;
  {
    Daemon d;
    d.keep();
    dir = d.dir();
    old_digest = upload_half(d);
    ASSERT_EQ(d.terminate(), 0);
  }
  const auto part = dir / "store" / "partial" / (old_digest.sha256() + ".part");
  ASSERT_TRUE(std::filesystem::exists(part));
  // Two days old, past the default age of one day.
  std::filesystem::last_write_time(part, std::filesystem::file_time_type::clock::now() - std::chrono::hours(48));
  Daemon again({}, dir);
  EXPECT_FALSE(std::filesystem::exists(part));
  EXPECT_NE(again.log().find("at start: deleted 1 partial upload(s)"), std::string::npos) << again.log();
  const v1::Digest young = upload_half(again);
  EXPECT_EQ(received(again, young), young.size() / 2);  // a fresh partial upload is kept to resume
}

}  // namespace
}  // namespace kiln
