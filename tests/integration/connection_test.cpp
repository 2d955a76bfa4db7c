// kilnd's connections under misuse and attack: id-0 errors and their codes, heartbeats, failed hellos, idle sockets.
// Each test starts the real daemon and speaks the protocol by hand over plain sockets.
#include <gtest/gtest.h>

#include <chrono>
#include <string>

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

}  // namespace
}  // namespace kiln
