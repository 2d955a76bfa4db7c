// kilnd's connections under misuse and attack: id-0 errors and their codes, heartbeats, failed hellos, idle sockets.
// Each test starts the real daemon and speaks the protocol by hand over plain sockets.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <string>
#include <vector>

#include "client/lib/client.h"
#include "proto/framing.h"
#include "proto/kiln.pb.h"
#include "tests/integration/daemon_fixture.h"
#include "tests/integration/raw_connection.h"

namespace kiln {
namespace {

using test::Daemon;
using test::RawConnection;

// The preamble of kiln.proto: an id-0 response is a connection-level error and the connection closes after it.
void expect_connection_error(RawConnection& raw, v1::Error::Code code, const std::string& what) {
  const auto r = raw.read();
  ASSERT_TRUE(r.has_value()) << what << ": closed without an id-0 error";
  EXPECT_EQ(r->id(), 0u) << what;
  EXPECT_EQ(r->error().code(), code) << what << ": " << r->error().message();
  EXPECT_TRUE(raw.closed_by_server()) << what << ": the connection stayed open after an id-0 error";
}

TEST(Connection, FrameThatIsNotARequestIsInvalidArgument) {
  Daemon d;
  RawConnection raw(test::port_of(d.tcp()));
  // One byte of payload: field 1 with wire type 7, which protobuf does not define.
  ASSERT_TRUE(raw.send_bytes(std::string("\x01\x0f", 2)));
  expect_connection_error(raw, v1::Error::INVALID_ARGUMENT, "a frame that is not a Request");
}

TEST(Connection, MalformedLengthIsInvalidArgumentAndOversizeIsResourceExhausted) {
  Daemon d;
  {
    RawConnection raw(test::port_of(d.tcp()));
    ASSERT_TRUE(raw.send_bytes(std::string(11, '\x80')));  // a varint longer than 10 bytes
    expect_connection_error(raw, v1::Error::INVALID_ARGUMENT, "a malformed length");
  }
  {
    RawConnection raw(test::port_of(d.tcp()));
    ASSERT_TRUE(raw.send_bytes("\x80\x80\x80\x80\x80\x20"));  // declares 2^40 bytes: a limit of the server
    expect_connection_error(raw, v1::Error::RESOURCE_EXHAUSTED, "an oversized frame");
  }
}

TEST(Connection, RequestWithIdZeroClosesTheConnection) {
  Daemon d;
  RawConnection raw(test::port_of(d.tcp()));
  ASSERT_TRUE(raw.send(test::hello_request(0, d.token())));
  expect_connection_error(raw, v1::Error::INVALID_ARGUMENT, "a request with id 0");
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

// HelloReply promises heartbeat_seconds; a watch with nothing new must hear from the server at least that often.
// The period is set to 1 s so the test is short. A job queued behind a long one has no progress, so every event
// after the first is a heartbeat. Before the fix the session checked on a fixed 1-period grid and skipped a watch
// just short of due, so the first gap was nearly 2 periods (~2.0 s here). Tolerance: 0.5 s for scheduling on a busy
// 2-core machine running a bake.
TEST(Connection, WatchHeartbeatsKeepThePromisedPeriod) {
  Daemon d({"--heartbeat", "1", "--workers", "1", "--shutdown-grace", "0.5"});
  client::Client c(d.tcp());
  c.hello(d.token());
  const std::string blocker = c.submit(long_material_job()).job_id();
  v1::JobSpec waiting = long_material_job();
  waiting.mutable_material()->mutable_ggx()->set_alpha(0.4);
  const std::string queued = c.submit(waiting).job_id();

  RawConnection raw(test::port_of(d.tcp()));
  const v1::Response hello = raw.call(test::hello_request(1, d.token()));
  ASSERT_EQ(hello.hello().limits().heartbeat_seconds(), 1u);
  v1::Request watch;
  watch.set_id(2);
  watch.mutable_watch()->set_job_id(queued);
  ASSERT_TRUE(raw.send(watch));
  std::vector<std::chrono::steady_clock::time_point> arrivals;
  const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(4500);
  while (std::chrono::steady_clock::now() < end) {
    const auto r = raw.read(std::chrono::seconds(3));
    ASSERT_TRUE(r.has_value()) << "no event for 3 s";
    ASSERT_EQ(r->id(), 2u);
    ASSERT_TRUE(r->has_event()) << r->error().message();
    EXPECT_EQ(r->event().state(), v1::JOB_STATE_QUEUED);
    arrivals.push_back(std::chrono::steady_clock::now());
  }
  ASSERT_GE(arrivals.size(), 4u);
  double widest = 0;
  for (size_t i = 1; i < arrivals.size(); ++i) {
    widest = std::max(widest, std::chrono::duration<double>(arrivals[i] - arrivals[i - 1]).count());
  }
  std::cout << "[ measured ] " << arrivals.size() << " events, widest gap " << widest << " s (promised 1 s)\n";
  EXPECT_LE(widest, 1.5);
  c.cancel(queued);
  c.cancel(blocker);
}

// A failed Hello closes the connection, and failures from one address are answered ever more slowly: the answer
// to the n-th wrong token in a row waits 50 ms * 2^(n-1) (at most 5 s), so guessing runs at a few per second at
// best instead of ~10,000. Before the fix the connection stayed open and every answer was immediate. Bounds: the
// waits are lower bounds (timers do not fire early); the upper bound only checks the answer still comes.
TEST(Connection, FailedHelloClosesAndRepeatedFailuresSlowDown) {
  Daemon d;
  const unsigned port = test::port_of(d.tcp());
  std::vector<double> seconds_per_answer;
  for (int i = 0; i < 6; ++i) {
    RawConnection raw(port);
    const auto start = std::chrono::steady_clock::now();
    const v1::Response r = raw.call(test::hello_request(1, "wrong-token-0123456789"));
    seconds_per_answer.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    EXPECT_EQ(r.id(), 1u);
    EXPECT_EQ(r.error().code(), v1::Error::UNAUTHENTICATED);
    EXPECT_EQ(r.error().field(), "hello.token");
    EXPECT_TRUE(raw.closed_by_server(std::chrono::seconds(3))) << "a failed hello left the connection open";
  }
  for (size_t i = 0; i < seconds_per_answer.size(); ++i) {
    std::cout << "[ measured ] wrong token " << i + 1 << " answered after " << seconds_per_answer[i] << " s\n";
  }
  EXPECT_GE(seconds_per_answer[5], 1.6);  // the 6th failure in a row: 50 ms * 2^5
  EXPECT_LT(seconds_per_answer[5], 10.0);
  // A right token from the same address is answered at once.
  RawConnection good(port);
  const auto start = std::chrono::steady_clock::now();
  const v1::Response ok = good.call(test::hello_request(1, d.token()));
  EXPECT_FALSE(ok.has_error()) << ok.error().message();
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 1.0);
}

}  // namespace
}  // namespace kiln
