// One client connection of kilnd: framed requests read and handed to the service, answers and watch events written
// one at a time with backpressure, heartbeats for open watches, and the frame and idle deadlines.
#pragma once

// Boost 1.74's Asio uses std::exchange without including <utility> itself.
#include <utility>

#include <boost/asio.hpp>

#include <memory>
#include <string>

namespace boost::asio::ssl {
class context;
}

namespace kiln::daemon {

class Service;

// The server's two bounds on connections, as a session sees them: a connection counts as "pre-hello" until its
// Hello succeeds, then as authenticated. Implemented by the server; called from the sessions' strands.
class ConnectionRegistry {
 public:
  virtual ~ConnectionRegistry() = default;
  // The session's Hello succeeded: true if it may stay (the authenticated connections are within
  // max_connections, counting it), false if it must be refused.
  virtual bool promote(uint64_t session_id) = 0;
  // The session ended (called from its destructor); `promoted` says which bound it counted against.
  virtual void closed(uint64_t session_id, bool promoted) = 0;
};

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
  // Unique for the daemon's life; the key of the session in the server's registry.
  virtual uint64_t id() const = 0;
};

// A session over an accepted TCP or Unix socket connection, run on its own strand of `io`. `registry` must outlive
// the session (it is told when the session ends). With `tls` (which must outlive the session too), a TCP session
// begins with a TLS handshake, within the hello deadline; a client that speaks plain TCP to it is told to use TLS.
std::shared_ptr<Session> make_session(boost::asio::io_context& io, Service& service, ConnectionRegistry& registry,
                                      boost::asio::ip::tcp::socket socket, boost::asio::ssl::context* tls);
std::shared_ptr<Session> make_session(boost::asio::io_context& io, Service& service, ConnectionRegistry& registry,
                                      boost::asio::local::stream_protocol::socket socket);

}  // namespace kiln::daemon
