// kilnd's network side: Boost.Asio listeners on TCP and a Unix socket, one session per connection, deadlines,
// a bound on connections, and writes queued one at a time with backpressure.
#pragma once

#include <memory>
#include <string>

namespace kiln::daemon {

class Service;

class Server {
 public:
  // Binds the listeners the service's configuration names. Throws std::runtime_error naming the address.
  explicit Server(Service& service);
  ~Server();

  // The TCP port actually bound (useful with port 0), or 0 without TCP.
  unsigned short tcp_port() const;

  // Runs the network threads until stop() (from a signal handler thread or elsewhere).
  void run(int threads);
  // Stops accepting, closes every connection, and makes run() return.
  void stop();

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace kiln::daemon
