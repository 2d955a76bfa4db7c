// One client connection of kilnd: framed requests read and handed to the service, answers and watch events written
// one at a time with backpressure, heartbeats for open watches, and the frame and idle deadlines.
#pragma once

// Boost 1.74's Asio uses std::exchange without including <utility> itself.
#include <utility>

#include <boost/asio.hpp>

#include <memory>
#include <string>

namespace kiln::daemon {

class Service;

class Session {
 public:
  virtual ~Session() = default;

  // Tells the service a connection opened, and starts reading requests.
  virtual void start() = 0;
  // Closes the connection from any thread; pending writes are dropped.
  virtual void close() = 0;
  // Refuses the connection at once (too many connections): one id-0 error, then close.
  virtual void refuse(const std::string& message) = 0;
  // Makes the session's end tell the service the connection closed (the server calls it before start()).
  virtual void mark_counted() = 0;
};

// A session over an accepted TCP or Unix socket connection, run on its own strand of `io`.
std::shared_ptr<Session> make_session(boost::asio::io_context& io, Service& service,
                                      boost::asio::ip::tcp::socket socket);
std::shared_ptr<Session> make_session(boost::asio::io_context& io, Service& service,
                                      boost::asio::local::stream_protocol::socket socket);

}  // namespace kiln::daemon
