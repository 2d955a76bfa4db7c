// The protocol spoken by hand over a plain TCP socket, for requests and byte streams the client library would never
// send, and for reading exactly what the daemon answers (id-0 errors, heartbeats, when it closes).
#pragma once

#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

#include "proto/framing.h"
#include "proto/kiln.pb.h"
#include "tests/integration/daemon_fixture.h"

namespace kiln::test {

class RawConnection {
 public:
  explicit RawConnection(unsigned port) : fd_(connect_tcp(port)) {
    if (fd_ < 0) throw std::runtime_error("cannot connect to 127.0.0.1:" + std::to_string(port));
  }
  ~RawConnection() { ::close(fd_); }
  RawConnection(const RawConnection&) = delete;
  RawConnection& operator=(const RawConnection&) = delete;

  int fd() const { return fd_; }

  // Sends raw bytes; false if the connection refused them.
  bool send_bytes(std::string_view bytes) {
    return ::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(bytes.size());
  }
  bool send(const v1::Request& request) { return send_bytes(proto::encode_frame(request)); }

  // The next response, or nothing if the server closed the connection or `limit` passed first.
  std::optional<v1::Response> read(std::chrono::milliseconds limit = std::chrono::seconds(10)) {
    std::string_view payload;
    while (decoder_.next(payload) != proto::FrameDecoder::Status::frame) {
      timeval tv{static_cast<time_t>(limit.count() / 1000), static_cast<suseconds_t>(limit.count() % 1000 * 1000)};
      ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
      char buf[65536];
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n <= 0) return std::nullopt;
      decoder_.feed(std::string_view(buf, static_cast<size_t>(n)));
    }
    v1::Response r;
    if (!proto::parse_frame(payload, r)) throw std::runtime_error("the server sent a frame that is not a Response");
    return r;
  }

  // Sends a request and returns the next response; throws if the connection closes first.
  v1::Response call(const v1::Request& request) {
    if (!send(request)) throw std::runtime_error("cannot send: connection closed");
    auto r = read();
    if (!r) throw std::runtime_error("connection closed");
    return *r;
  }

  // True if the server closes the connection within `limit` (whatever it sends before).
  bool closed_by_server(std::chrono::milliseconds limit = std::chrono::seconds(10)) {
    const auto end = std::chrono::steady_clock::now() + limit;
    timeval tv{0, 100 * 1000};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    char buf[4096];
    while (std::chrono::steady_clock::now() < end) {
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n == 0) return true;
      if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK) return errno == ECONNRESET;
    }
    return false;
  }

 private:
  int fd_;
  proto::FrameDecoder decoder_;
};

inline v1::Request hello_request(uint64_t id, const std::string& token) {
  v1::Request r;
  r.set_id(id);
  r.mutable_hello()->set_protocol_version(proto::kProtocolVersion);
  r.mutable_hello()->set_token(token);
  return r;
}

inline v1::Request status_request(uint64_t id) {
  v1::Request r;
  r.set_id(id);
  r.mutable_status();
  return r;
}

}  // namespace kiln::test
