// The service end to end: the real kilnd on loopback and a Unix socket, driven by the real client library.
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <future>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "client/lib/client.h"
#include "proto/digest.h"
#include "proto/framing.h"
#include "proto/kiln.pb.h"
#include "tests/integration/daemon_fixture.h"
#include "tests/integration/raw_connection.h"
#include "tests/integration/service_client.h"
#include "tests/support/sanitizers.h"

namespace kiln {
namespace {

using client::Client;
using test::connect;
using test::Daemon;
using test::ggx_job;

// Reads what the daemon sends on a raw socket until it closes (or 10 s pass); returns true if it closed.
bool closed_by_server(int fd, std::chrono::seconds limit = std::chrono::seconds(10)) {
  timeval tv{static_cast<time_t>(limit.count()), 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  char buf[4096];
  for (;;) {
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n == 0) return true;
    if (n < 0) return errno == ECONNRESET;
  }
}

TEST(Daemon, SubmitWatchFetchOverTcpAndUnixSocket) {
  Daemon d;
  for (bool unix_socket : {false, true}) {
    Client c = connect(d, unix_socket);
    const v1::SubmitReply sub = c.submit(ggx_job(unix_socket ? 0.4 : 0.3));
    EXPECT_FALSE(sub.cache_hit());
    int events = 0;
    double last_fraction = 0;
    const v1::JobEvent last = c.watch(sub.job_id(), [&](const v1::JobEvent& e) {
      ++events;
      EXPECT_GE(e.fraction(), last_fraction);  // progress never goes backwards
      last_fraction = e.fraction();
    });
    EXPECT_TRUE(last.final());
    ASSERT_EQ(last.state(), v1::JOB_STATE_SUCCEEDED) << last.message() << d.log();
    EXPECT_GE(events, 2);
    const v1::JobResult r = c.result(sub.job_id());
    ASSERT_EQ(r.state(), v1::JOB_STATE_SUCCEEDED);
    std::set<std::string> names;
    for (const v1::Output& o : r.outputs()) {
      names.insert(o.name());
      const std::string bytes = c.fetch(o.digest());  // the library verifies the digest too
      EXPECT_EQ(bytes.size(), o.digest().size());
      EXPECT_EQ(proto::sha256_hex(bytes), o.digest().sha256());
    }
    EXPECT_EQ(names, (std::set<std::string>{"albedo.exr", "split_sum.exr", "preview.png", "report.json"}));
    EXPECT_GT(r.report().samples(), 0u);
    EXPECT_GT(r.report().seconds(), 0.0);
    EXPECT_GT(r.report().error_estimate(), 0.0);
    EXPECT_FALSE(r.report().json().empty());
  }
}

// Several jobs followed on one connection (Client::start_watch, kiln build's way): every job's events arrive, each
// watch ends with its final event, and events that arrive while another request waits for its answer are kept.
TEST(Daemon, SeveralWatchesShareOneConnection) {
  Daemon d;
  client::Client c = test::connect(d);
  std::vector<std::string> ids;
  for (double alpha : {0.21, 0.22, 0.23}) ids.push_back(c.submit(test::ggx_job(alpha, 4096)).job_id());
  for (const auto& id : ids) c.start_watch(id);
  EXPECT_EQ(c.watching(), 3u);
  std::map<std::string, int> events, finals;
  while (c.watching() > 0) {
    const client::Client::WatchEvent e = c.next_watch_event();
    ASSERT_FALSE(e.error) << e.error->message();
    EXPECT_EQ(e.event.job_id(), e.job_id);
    ++events[e.job_id];
    if (e.event.final()) {
      ++finals[e.job_id];
      EXPECT_EQ(e.event.state(), v1::JOB_STATE_SUCCEEDED);
      // A request in between: its answer comes through while the other watches go on.
      EXPECT_EQ(c.result(e.job_id).state(), v1::JOB_STATE_SUCCEEDED);
      c.status();
    }
  }
  for (const auto& id : ids) {
    EXPECT_GE(events[id], 1) << id;
    EXPECT_EQ(finals[id], 1) << id;
  }
  // A watch of an unknown job ends with its error, naming the job.
  c.start_watch("no-such-job");
  const client::Client::WatchEvent e = c.next_watch_event();
  EXPECT_EQ(e.job_id, "no-such-job");
  ASSERT_TRUE(e.error);
  EXPECT_EQ(e.error->code(), v1::Error::NOT_FOUND);
  EXPECT_EQ(c.watching(), 0u);
}

TEST(Daemon, IdenticalJobIsACacheHitWithTheSameDigests) {
  Daemon d;
  Client c = connect(d);
  const auto first = c.submit(ggx_job(0.5));
  ASSERT_EQ(c.watch(first.job_id()).state(), v1::JOB_STATE_SUCCEEDED);
  v1::JobSpec again = ggx_job(0.5);
  again.set_name("another name, same bake");
  const auto second = c.submit(again);
  EXPECT_TRUE(second.cache_hit());
  EXPECT_EQ(second.state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_NE(second.job_id(), first.job_id());
  const auto r1 = c.result(first.job_id()), r2 = c.result(second.job_id());
  ASSERT_EQ(r1.outputs_size(), r2.outputs_size());
  for (int i = 0; i < r1.outputs_size(); ++i)
    EXPECT_EQ(r1.outputs(i).digest().sha256(), r2.outputs(i).digest().sha256());
  EXPECT_TRUE(r2.report().cache_hit());
  EXPECT_EQ(c.status().cache_hits(), 1u);
}

TEST(Daemon, WrongOrMissingTokenIsRefusedOnTcp) {
  Daemon d;
  for (const std::string& token : std::vector<std::string>{"", "wrong-token-0123456789", d.token() + "x"}) {
    Client c(d.tcp());
    try {
      c.hello(token);
      ADD_FAILURE() << "accepted token '" << token << "'";
    } catch (const client::ServerError& e) {
      EXPECT_EQ(e.code(), v1::Error::UNAUTHENTICATED) << e.what();
      EXPECT_EQ(e.field(), "token");
    }
  }
  // Without hello nothing is answered but UNAUTHENTICATED.
  Client c(d.tcp());
  try {
    c.status();
    ADD_FAILURE();
  } catch (const client::ServerError& e) {
    EXPECT_EQ(e.code(), v1::Error::UNAUTHENTICATED);
  }
  // The Unix socket's permissions decide: no token needed, and the socket is its owner's alone.
  Client u(d.unix_address());
  EXPECT_NO_THROW(u.hello(""));
  const auto perms = std::filesystem::status(d.dir() / "kilnd.sock").permissions();
  EXPECT_EQ(perms & (std::filesystem::perms::group_all | std::filesystem::perms::others_all),
            std::filesystem::perms::none);
}

TEST(Daemon, BadStreamsAreDroppedAndOthersStillServed) {
  Daemon d({"--frame-deadline", "1"});
  const unsigned port = test::port_of(d.tcp());
  Client good = connect(d);
  {  // a frame declaring 2^40 bytes: refused as soon as its length arrives
    const int fd = test::connect_tcp(port);
    const unsigned char header[] = {0x80, 0x80, 0x80, 0x80, 0x80, 0x20};
    ASSERT_EQ(::send(fd, header, sizeof header, 0), static_cast<ssize_t>(sizeof header));
    EXPECT_TRUE(closed_by_server(fd));
    ::close(fd);
  }
  {  // random bytes
    const int fd = test::connect_tcp(port);
    std::string junk(4096, '\0');
    for (size_t i = 0; i < junk.size(); ++i) junk[i] = static_cast<char>((i * 2654435761u) >> 13);
    ::send(fd, junk.data(), junk.size(), MSG_NOSIGNAL);
    EXPECT_TRUE(closed_by_server(fd));
    ::close(fd);
  }
  {  // a truncated frame, then nothing: the frame deadline (1 s here) drops it
    const int fd = test::connect_tcp(port);
    const unsigned char partial[] = {0x20, 0x08, 0x01};  // declares 32 bytes, sends 2
    ::send(fd, partial, sizeof partial, MSG_NOSIGNAL);
    EXPECT_TRUE(closed_by_server(fd, std::chrono::seconds(10)));
    ::close(fd);
  }
  EXPECT_NO_THROW(good.status());  // still served
  EXPECT_NE(d.log().find("dropped"), std::string::npos);
}

using test::RawConnection;

v1::Request put(uint64_t id, const std::string& sha, uint64_t size, uint64_t offset, std::string data) {
  v1::Request r;
  r.set_id(id);
  r.mutable_blob_put()->mutable_digest()->set_sha256(sha);
  r.mutable_blob_put()->mutable_digest()->set_size(size);
  r.mutable_blob_put()->set_offset(offset);
  r.mutable_blob_put()->set_data(std::move(data));
  return r;
}

TEST(Daemon, BlobDigestIsVerifiedAndUploadsResume) {
  Daemon d;
  Client c = connect(d);
  std::string data(3 << 20, '\0');
  for (size_t i = 0; i < data.size(); ++i) data[i] = static_cast<char>(i * 31 + (i >> 11));
  const v1::Digest digest = c.upload_blob(data);  // several 1 MiB chunks
  EXPECT_EQ(digest.sha256(), proto::sha256_hex(data));
  EXPECT_EQ(c.query_blobs({digest}).missing_size(), 0);
  EXPECT_EQ(c.fetch(digest), data);

  RawConnection raw(test::port_of(d.tcp()));
  v1::Request hello;
  hello.set_id(1);
  hello.mutable_hello()->set_protocol_version(1);
  hello.mutable_hello()->set_token(d.token());
  ASSERT_FALSE(raw.call(hello).has_error());

  // Bytes that do not hash to the declared digest: the completing chunk is answered DATA_LOSS and nothing is kept.
  const std::string claimed = proto::sha256_hex("the real content");
  const v1::Response bad = raw.call(put(2, claimed, 5, 0, "fake!"));
  ASSERT_TRUE(bad.has_error());
  EXPECT_EQ(bad.error().code(), v1::Error::DATA_LOSS) << bad.error().message();
  v1::Digest claimed_digest;
  claimed_digest.set_sha256(claimed);
  claimed_digest.set_size(5);
  const auto after = c.query_blobs({claimed_digest});
  ASSERT_EQ(after.missing_size(), 1);
  EXPECT_EQ(after.missing(0).received(), 0u);

  // An upload broken half-way: the server holds the first half, the client library resumes from there.
  std::string blob(2 << 20, '\0');
  for (size_t i = 0; i < blob.size(); ++i) blob[i] = static_cast<char>(i * 7 + 3);
  const std::string sha = proto::sha256_hex(blob);
  const v1::Response half = raw.call(put(3, sha, blob.size(), 0, blob.substr(0, 1 << 20)));
  ASSERT_FALSE(half.has_error()) << half.error().message();
  EXPECT_EQ(half.blob_put().received(), 1u << 20);
  // A chunk at the wrong offset is refused with the offset to resume from.
  const v1::Response wrong = raw.call(put(4, sha, blob.size(), 12345, "x"));
  ASSERT_TRUE(wrong.has_error());
  EXPECT_EQ(wrong.error().code(), v1::Error::FAILED_PRECONDITION);
  EXPECT_EQ(wrong.error().field(), "offset");
  v1::Digest blob_digest;
  blob_digest.set_sha256(sha);
  blob_digest.set_size(blob.size());
  EXPECT_EQ(c.query_blobs({blob_digest}).missing(0).received(), 1u << 20);
  uint64_t uploaded_from = 0;
  c.upload_blob(blob, [&](uint64_t done, uint64_t) {
    if (uploaded_from == 0) uploaded_from = done;
  });
  EXPECT_GE(uploaded_from, 1u << 20) << "the upload started over instead of resuming";
  EXPECT_EQ(c.fetch(blob_digest), blob);
}

// Several clients uploading the same blob at once (parallel bakes of one sky): each chunk may find the server's
// offset moved by another client, and every upload still ends with the blob stored, however often that happens.
TEST(Daemon, ConcurrentUploadsOfOneBlobAllSucceed) {
  Daemon d;
  std::string blob(8 << 20, '\0');
  for (size_t i = 0; i < blob.size(); ++i) blob[i] = static_cast<char>(i * 13 + (i >> 9));
  constexpr int kClients = 4;
  std::vector<std::future<v1::Digest>> uploads;
  for (int k = 0; k < kClients; ++k) {
    uploads.push_back(std::async(std::launch::async, [&] { return connect(d).upload_blob(blob); }));
  }
  for (auto& u : uploads) EXPECT_EQ(u.get().sha256(), proto::sha256_hex(blob));
  Client c = connect(d);
  v1::Digest digest;
  digest.set_sha256(proto::sha256_hex(blob));
  digest.set_size(blob.size());
  EXPECT_EQ(c.fetch(digest), blob);
}

TEST(Daemon, InvalidFieldsAreNamed) {
  Daemon d;
  Client c = connect(d);
  struct Case {
    std::function<void(v1::JobSpec&)> edit;
    const char* field;
  };
  const std::vector<Case> cases = {
      {[](v1::JobSpec& s) { s.mutable_material()->mutable_ggx()->set_alpha(-0.2); }, "job.material.ggx.alpha"},
      {[](v1::JobSpec& s) { s.mutable_material()->set_table_mu(0); }, "job.material.table_mu"},
      {[](v1::JobSpec& s) { s.mutable_quality()->set_target_error(-1); }, "job.quality.target_error"},
      {[](v1::JobSpec& s) { s.clear_material(); }, "job"},
      {[](v1::JobSpec& s) { s.mutable_material()->mutable_schlick()->set_r(3); }, "job.material.schlick.r"},
  };
  for (const Case& k : cases) {
    v1::JobSpec spec = ggx_job(0.3);
    k.edit(spec);
    try {
      c.submit(spec);
      ADD_FAILURE() << "accepted, expected an error on " << k.field;
    } catch (const client::ServerError& e) {
      EXPECT_EQ(e.code(), v1::Error::INVALID_ARGUMENT);
      EXPECT_EQ(e.field(), k.field) << e.what();
    }
  }
  try {
    c.submit(ggx_job(0.3), 1000);
    ADD_FAILURE();
  } catch (const client::ServerError& e) {
    EXPECT_EQ(e.field(), "priority");
  }
}

TEST(Daemon, CancelStopsARunningJobPromptly) {
  Daemon d;
  Client c = connect(d);
  // Large enough to run for many seconds.
  const auto sub = c.submit(ggx_job(0.3, 1 << 20, 64));
  Client w = connect(d);
  std::promise<void> running;
  bool signalled = false;
  auto watcher = std::async(std::launch::async, [&] {
    return w.watch(sub.job_id(), [&](const v1::JobEvent& e) {
      if (e.state() == v1::JOB_STATE_RUNNING && e.fraction() > 0 && !signalled) {
        signalled = true;
        running.set_value();
      }
    });
  });
  ASSERT_EQ(running.get_future().wait_for(std::chrono::seconds(60)), std::future_status::ready);
  c.cancel(sub.job_id());
  // The job is sized to bake for minutes (64 x 64 tables at 2^20 samples per entry); ending CANCELLED shows the
  // bake stopped at a cancel check (every 65536 samples) instead of running to the end. No clock is read: the
  // test's promptness is what the job's size guarantees, and CTest's timeout catches a hang.
  const v1::JobEvent last = watcher.get();
  EXPECT_EQ(last.state(), v1::JOB_STATE_CANCELLED);
  EXPECT_LT(last.fraction(), 1.0);
  EXPECT_EQ(c.result(sub.job_id()).state(), v1::JOB_STATE_CANCELLED);
}

TEST(Daemon, KillNineThenRestartCompletesEveryJob) {
  std::vector<std::string> ids;
  std::filesystem::path dir;
  {
    Daemon d;
    d.keep();
    dir = d.dir();
    Client c = connect(d);
    for (int i = 0; i < 4; ++i) ids.push_back(c.submit(ggx_job(0.2 + 0.1 * i, 1 << 16, 16)).job_id());
    // Wait until the first one runs, then crash.
    for (int i = 0; i < 200; ++i) {
      if (c.result(ids[0]).state() != v1::JOB_STATE_QUEUED) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    d.kill9();
  }
  Daemon again({}, dir);
  Client c = connect(again);
  for (const std::string& id : ids) {
    const v1::JobEvent last = c.watch(id);
    ASSERT_EQ(last.state(), v1::JOB_STATE_SUCCEEDED) << id << ": " << last.message() << again.log();
    const v1::JobResult r = c.result(id);
    for (const v1::Output& o : r.outputs()) EXPECT_EQ(proto::sha256_hex(c.fetch(o.digest())), o.digest().sha256());
  }
}

TEST(Daemon, TwentyClientsFiveJobsEach) {
  Daemon d({"--workers", "2"});
  const long rss_before = d.rss_kib();
  std::atomic<int> succeeded{0};
  std::vector<std::thread> clients;
  for (int k = 0; k < 20; ++k) {
    clients.emplace_back([&, k] {
      Client c = connect(d, k % 2 == 1);
      std::vector<std::string> ids;
      for (int j = 0; j < 5; ++j) ids.push_back(c.submit(ggx_job(0.05 + 0.009 * (k * 5 + j), 256, 4)).job_id());
      for (const auto& id : ids) {
        if (c.watch(id).state() == v1::JOB_STATE_SUCCEEDED) ++succeeded;
      }
    });
  }
  for (auto& t : clients) t.join();
  EXPECT_EQ(succeeded.load(), 100) << d.log();
  const long rss_after = d.rss_kib();
  // 100 small jobs: the daemon's memory may grow by its caches, but not by anything like the work done. (Under
  // AddressSanitizer the RSS holds its quarantine and shadow; LeakSanitizer checks kilnd's leaks at its exit.)
  if (!test::kUnderAddressSanitizer) {
    EXPECT_LT(rss_after, rss_before + 200 * 1024) << rss_before << " KiB -> " << rss_after << " KiB";
  }
  std::cout << "[ measured ] kilnd RSS " << rss_before << " KiB before, " << rss_after << " KiB after 100 jobs\n";
}

// SIGTERM with a job running past the grace period: the daemon exits cleanly, the job goes back to the queue, and
// the next start runs it to the end.
TEST(Daemon, ShutdownRequeuesWhatDidNotFinish) {
  std::filesystem::path dir;
  std::string id;
  {
    Daemon d({"--shutdown-grace", "0.5"});
    d.keep();
    dir = d.dir();
    Client c = connect(d);
    id = c.submit(ggx_job(0.3, 1 << 16, 16)).job_id();  // runs for seconds, past the 0.5 s grace
    for (int i = 0; i < 500 && c.result(id).state() != v1::JOB_STATE_RUNNING; ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    ASSERT_EQ(c.result(id).state(), v1::JOB_STATE_RUNNING);
    EXPECT_EQ(d.terminate(), 0) << d.log();
    EXPECT_NE(d.log().find("re-queued"), std::string::npos) << d.log();
  }
  Daemon again({}, dir);
  Client c = connect(again);
  const v1::JobEvent last = c.watch(id);
  EXPECT_EQ(last.state(), v1::JOB_STATE_SUCCEEDED) << last.message() << again.log();
}

TEST(Daemon, SigtermExitsCleanly) {
  Daemon d;
  { Client c = connect(d); }
  EXPECT_EQ(d.terminate(), 0);
}

}  // namespace
}  // namespace kiln
