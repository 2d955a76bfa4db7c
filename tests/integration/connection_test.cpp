// kilnd's connections under misuse and attack: id-0 errors and their codes, heartbeats, failed hellos, idle sockets.
// Each test starts the real daemon and speaks the protocol by hand over plain sockets.
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "client/lib/client.h"
#include "proto/framing.h"
#include "proto/kiln.pb.h"
#include "tests/integration/daemon_fixture.h"
#include "tests/integration/raw_connection.h"
#include "tests/integration/service_client.h"

namespace kiln {
namespace {

using test::Daemon;
using test::ggx_job;
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

// HelloReply promises heartbeat_seconds; a watch with nothing new must hear from the server at least that often.
// The period is set to 1 s so the test is short. A job queued behind a long one has no progress, so every event
// after the first is a heartbeat. Before the fix the session checked on a fixed 1-period grid and skipped a watch
// just short of due, so the first gap was nearly 2 periods (~2.0 s here). Tolerance: 0.5 s for scheduling on a busy
// 2-core machine running a bake.
TEST(Connection, WatchHeartbeatsKeepThePromisedPeriod) {
  Daemon d({"--heartbeat", "1", "--workers", "1", "--shutdown-grace", "0.5"});
  client::Client c = test::connect(d);
  const std::string blocker = c.submit(ggx_job(0.3, 1 << 20, 64)).job_id();
  const std::string queued = c.submit(ggx_job(0.4, 1 << 20, 64)).job_id();

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
    EXPECT_EQ(r.error().field(), "token");
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

// Holding many sockets needs as many descriptors in this process as in kilnd.
void fit_open_file_limit(rlim_t needed) {
  rlimit l{};
  ASSERT_EQ(::getrlimit(RLIMIT_NOFILE, &l), 0);
  if (l.rlim_cur != RLIM_INFINITY && l.rlim_cur < needed) {
    ASSERT_TRUE(l.rlim_max == RLIM_INFINITY || l.rlim_max >= needed) << "hard open-file limit " << l.rlim_max;
    l.rlim_cur = needed;
    ASSERT_EQ(::setrlimit(RLIMIT_NOFILE, &l), 0);
  }
}

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// 1,000 connections that never say Hello used to fill the 64-connection bound and lock every client out for the
// 600 s idle timeout. Now they count against their own bound (1,024 by default) and a client is served beside
// them. The hello deadline is raised to 60 s here so that all of them are still held while the client is timed.
// Figures (printed): the client's connect + hello + status, and one status round trip; the bound asserted is
// generous (2 s, for a loaded CI machine), the goal is under 100 ms.
TEST(Connection, AThousandIdleSocketsDoNotLockOutAClient) {
  fit_open_file_limit(4096);
  Daemon d({"--hello-deadline", "60"});
  const unsigned port = test::port_of(d.tcp());
  std::vector<std::unique_ptr<RawConnection>> idle;
  for (int i = 0; i < 1000; ++i) idle.push_back(std::make_unique<RawConnection>(port));

  const auto start = std::chrono::steady_clock::now();
  client::Client c = test::connect(d);
  v1::ServerStatus status = c.status();
  const double first = seconds_since(start);
  const auto again = std::chrono::steady_clock::now();
  status = c.status();
  const double round_trip = seconds_since(again);
  std::cout << "[ measured ] with 1000 idle sockets held: connect + hello + status " << first * 1000
            << " ms, status round trip " << round_trip * 1000 << " ms, kilnd counts " << status.connections()
            << " connections\n";
  EXPECT_GE(status.connections(), 1001u);  // the idle sockets are really held
  EXPECT_LT(first, 2.0);
  EXPECT_LT(round_trip, 2.0);
}

// A connection that never says Hello is closed at the hello deadline, with an id-0 DEADLINE_EXCEEDED.
TEST(Connection, SilentSocketIsClosedAtTheHelloDeadline) {
  Daemon d({"--hello-deadline", "1"});
  RawConnection raw(test::port_of(d.tcp()));
  const auto start = std::chrono::steady_clock::now();
  expect_connection_error(raw, v1::Error::DEADLINE_EXCEEDED, "no hello");
  EXPECT_GE(seconds_since(start), 0.9);  // not before the deadline (timers do not fire early; 0.1 s for the clock)
  // A client that says hello at once is not affected, and keeps its connection past the deadline.
  client::Client c = test::connect(d);
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  EXPECT_NO_THROW(c.status());
}

// When the pre-hello bound is full, the oldest connection that has not said hello is dropped for the new one.
TEST(Connection, PreHelloBoundDropsTheOldestFirst) {
  Daemon d({"--max-pre-hello-connections", "4", "--hello-deadline", "60"});
  const unsigned port = test::port_of(d.tcp());
  std::vector<std::unique_ptr<RawConnection>> raws;
  for (int i = 0; i < 4; ++i) {
    raws.push_back(std::make_unique<RawConnection>(port));
    // Accept order is connect order only if each connection is accepted before the next: a status with no hello
    // (answered UNAUTHENTICATED) proves it was.
    const v1::Response r = raws.back()->call(test::status_request(1));
    ASSERT_EQ(r.error().code(), v1::Error::UNAUTHENTICATED);
  }
  RawConnection newest(port);
  expect_connection_error(*raws[0], v1::Error::RESOURCE_EXHAUSTED, "the oldest pre-hello connection");
  for (int i = 1; i < 4; ++i)
    EXPECT_EQ(raws[i]->call(test::status_request(2)).error().code(), v1::Error::UNAUTHENTICATED);
  // A client still gets in (dropping the next oldest), and says hello.
  client::Client c(d.tcp());
  EXPECT_NO_THROW(c.hello(d.token()));
  EXPECT_NO_THROW(c.status());
}

// max_connections bounds the connections that said hello: one more hello is refused RESOURCE_EXHAUSTED, and a
// slot that frees up can be taken again.
TEST(Connection, HelloPastMaxConnectionsIsRefused) {
  Daemon d({"--max-connections", "2"});
  auto a = std::make_unique<client::Client>(d.tcp());
  a->hello(d.token());
  client::Client b(d.tcp());
  b.hello(d.token());
  client::Client c(d.tcp());
  try {
    c.hello(d.token());
    ADD_FAILURE() << "a third hello was accepted with --max-connections 2";
  } catch (const client::ServerError& e) {
    EXPECT_EQ(e.code(), v1::Error::RESOURCE_EXHAUSTED) << e.what();
  }
  a.reset();  // frees a slot once kilnd sees the close
  bool admitted = false;
  for (int i = 0; i < 100 && !admitted; ++i) {
    try {
      client::Client again(d.tcp());
      again.hello(d.token());
      admitted = true;
    } catch (const client::ServerError&) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  }
  EXPECT_TRUE(admitted);
}

}  // namespace
}  // namespace kiln
