#include "daemon/server.h"

// Boost 1.74's Asio uses std::exchange without including <utility> itself.
#include <utility>

#include <boost/asio.hpp>
#include <boost/asio/ssl/context.hpp>

#include <sys/socket.h>
#include <sys/stat.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <thread>

#include "daemon/log.h"
#include "daemon/service.h"
#include "daemon/session.h"
#include "daemon/tls_context.h"

namespace kiln::daemon {

namespace asio = boost::asio;
using asio::ip::tcp;
using unix_socket = asio::local::stream_protocol;

// Two bounds on connections. Those that said Hello count against max_connections; a Hello past it is refused.
// Those that have not (yet) count against max_pre_hello_connections, a larger bound: when it is full, the oldest
// pre-hello connection is dropped to make room for the new one, so idle sockets that never say Hello (each of
// which the hello deadline closes anyway) can never lock clients out.
struct Server::Impl : ConnectionRegistry {
  Service& service;
  // Declared before the io_context: sessions destroyed with its pending handlers still report to the registry.
  std::mutex registry_mutex;
  std::map<uint64_t, std::weak_ptr<Session>> pre_hello;  // by session id, which grows with accept order
  std::size_t authenticated = 0;
  std::mutex sessions_mutex;
  std::set<std::weak_ptr<Session>, std::owner_less<std::weak_ptr<Session>>> sessions;  // so stop() can close them

  std::unique_ptr<asio::ssl::context> tls;  // TLS on the TCP listener, if configured; outlives the sessions
  asio::io_context io;
  std::optional<tcp::acceptor> tcp_acceptor;
  std::optional<unix_socket::acceptor> unix_acceptor;
  std::string unix_path;
  std::atomic<bool> stopping{false};

  explicit Impl(Service& s) : service(s) {}
  template <class Acceptor>
  void accept(Acceptor& acceptor);
  template <class Acceptor>
  void accept_later(Acceptor& acceptor);
  void admit(const std::shared_ptr<Session>& session);
  std::shared_ptr<Session> new_session(tcp::socket s) {
    return make_session(io, service, *this, std::move(s), tls.get());
  }
  std::shared_ptr<Session> new_session(unix_socket::socket s) { return make_session(io, service, *this, std::move(s)); }

  bool promote(uint64_t session_id) override {
    std::lock_guard lock(registry_mutex);
    pre_hello.erase(session_id);
    if (authenticated >= service.config().max_connections) return false;
    ++authenticated;
    return true;
  }
  void closed(uint64_t session_id, bool promoted) override {
    std::lock_guard lock(registry_mutex);
    if (promoted) {
      --authenticated;
    } else {
      pre_hello.erase(session_id);
    }
  }
};

void Server::Impl::admit(const std::shared_ptr<Session>& session) {
  std::shared_ptr<Session> dropped;
  std::size_t waiting;
  {
    std::lock_guard lock(registry_mutex);
    pre_hello.emplace(session->id(), session);
    waiting = pre_hello.size();
    if (waiting > service.config().max_pre_hello_connections) {
      dropped = pre_hello.begin()->second.lock();
      pre_hello.erase(pre_hello.begin());
    }
  }
  {
    std::lock_guard lock(sessions_mutex);
    for (auto it = sessions.begin(); it != sessions.end();) it = it->expired() ? sessions.erase(it) : ++it;
    sessions.insert(session);
  }
  session->mark_counted();
  session->start();
  if (dropped) {
    dropped->refuse("dropped to make room: the server holds " + std::to_string(waiting - 1) +
                    " connections that have not said hello, its limit (max_pre_hello_connections), and the oldest "
                    "go first; say hello as soon as you connect");
  }
}

template <class Acceptor>
void Server::Impl::accept(Acceptor& acceptor) {
  acceptor.async_accept(asio::make_strand(io), [this, &acceptor](const boost::system::error_code& ec,
                                                                 typename Acceptor::protocol_type::socket s) {
    if (stopping) return;
    if (!ec) {
      admit(new_session(std::move(s)));
    } else if (ec != asio::error::operation_aborted) {
      // Out of file descriptors (or another transient failure): the pending connection stays in the backlog, so
      // accepting again at once would spin. Pause briefly; closing connections frees descriptors meanwhile.
      log_line("listener", "accept failed: " + ec.message() + "; pausing accepts for 100 ms");
      return accept_later(acceptor);
    }
    accept(acceptor);
  });
}

template <class Acceptor>
void Server::Impl::accept_later(Acceptor& acceptor) {
  auto timer = std::make_shared<asio::steady_timer>(io, std::chrono::milliseconds(100));
  timer->async_wait([this, &acceptor, timer](const boost::system::error_code& ec) {
    if (!ec && !stopping) accept(acceptor);
  });
}

namespace {

// A socket file left by a previous run that died would make bind fail, so it is removed, but only once it is known
// to be dead: a socket some process still listens on is never unlinked (that would cut a running kilnd off from
// its clients). Throws std::runtime_error naming the process that listens, when the kernel says which.
void remove_stale_socket(asio::io_context& io, const std::string& path) {
  std::error_code fs_ec;
  if (!std::filesystem::is_socket(path, fs_ec)) return;  // absent, or not a socket: bind reports it
  unix_socket::socket probe(io);
  boost::system::error_code ec;
  probe.connect(unix_socket::endpoint(path), ec);
  if (!ec) {
    std::string holder = "a live process";
    ucred cred{};
    socklen_t len = sizeof cred;
    if (::getsockopt(probe.native_handle(), SOL_SOCKET, SO_PEERCRED, &cred, &len) == 0 && cred.pid > 0) {
      holder = "process " + std::to_string(cred.pid);
      std::ifstream comm("/proc/" + std::to_string(cred.pid) + "/comm");
      std::string name;
      if (std::getline(comm, name) && !name.empty()) holder += " (" + name + ")";
    }
    throw std::runtime_error("--socket " + path + ": " + holder +
                             " is listening on it; another kilnd is probably running. Stop it, or give this one "
                             "another --socket path");
  }
  if (ec != asio::error::connection_refused) {
    throw std::runtime_error("--socket " + path + ": cannot tell whether a process listens on it (" + ec.message() +
                             "); remove the file if no daemon uses it, or give another --socket path");
  }
  std::filesystem::remove(path, fs_ec);
}

}  // namespace

Server::Server(Service& service) : impl_(std::make_unique<Impl>(service)) {
  const Config& c = service.config();
  if (!c.listen.empty()) {
    const auto colon = c.listen.rfind(':');
    std::string host = c.listen.substr(0, colon);
    if (host.size() >= 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
    const std::string port = c.listen.substr(colon + 1);
    tcp::resolver resolver(impl_->io);
    boost::system::error_code ec;
    const auto results = resolver.resolve(host, port, tcp::resolver::passive, ec);
    if (ec || results.empty())
      throw std::runtime_error("--listen " + c.listen + ": cannot resolve (" + ec.message() + ")");
    const tcp::endpoint ep = results.begin()->endpoint();
    impl_->tls = make_tls_context(c);
    if (!impl_->tls && !ep.address().is_loopback()) {
      if (!c.insecure_tcp) {
        throw std::runtime_error(
            "--listen " + c.listen + ": " + ep.address().to_string() +
            " is not a loopback address, and without TLS the clients' tokens would cross the network in clear. Give "
            "--tls-cert FILE and --tls-key FILE (docs/SECURITY.md), or --insecure-tcp if the network is protected "
            "otherwise (a VPN, an SSH tunnel)");
      }
      log_line("listener", "--insecure-tcp: listening on " + ep.address().to_string() +
                               " without TLS; tokens and jobs cross the network in clear");
    }
    if (impl_->tls) log_line("listener", describe_tls(c, *impl_->tls));
    tcp::acceptor a(impl_->io);
    a.open(ep.protocol(), ec);
    if (!ec) a.set_option(tcp::acceptor::reuse_address(true), ec);
    if (!ec) a.bind(ep, ec);
    if (!ec) a.listen(asio::socket_base::max_listen_connections, ec);
    if (ec) throw std::runtime_error("--listen " + c.listen + ": cannot listen (" + ec.message() + ")");
    impl_->tcp_acceptor.emplace(std::move(a));
    impl_->accept(*impl_->tcp_acceptor);
  }
  if (!c.socket.empty()) {
    remove_stale_socket(impl_->io, c.socket);
    boost::system::error_code ec;
    unix_socket::acceptor a(impl_->io);
    a.open(unix_socket(), ec);
    // Whoever can open the socket file may talk to kilnd without a token, so it is created for its owner only
    // (mode 0600; widen it with chmod/chgrp deliberately). umask, not chmod after bind, leaves no window.
    const mode_t old_mask = ::umask(0077);
    if (!ec) a.bind(unix_socket::endpoint(c.socket), ec);
    ::umask(old_mask);
    if (!ec) a.listen(asio::socket_base::max_listen_connections, ec);
    if (ec) throw std::runtime_error("--socket " + c.socket + ": cannot listen (" + ec.message() + ")");
    impl_->unix_path = c.socket;
    impl_->unix_acceptor.emplace(std::move(a));
    impl_->accept(*impl_->unix_acceptor);
  }
}

Server::~Server() {
  stop();
  if (!impl_->unix_path.empty()) {
    std::error_code ec;
    std::filesystem::remove(impl_->unix_path, ec);
  }
}

unsigned short Server::tcp_port() const {
  return impl_->tcp_acceptor ? impl_->tcp_acceptor->local_endpoint().port() : 0;
}

void Server::run(int threads) {
  std::vector<std::thread> pool;
  for (int i = 1; i < threads; ++i) pool.emplace_back([this] { impl_->io.run(); });
  impl_->io.run();
  for (auto& t : pool) t.join();
}

void Server::stop() {
  if (impl_->stopping.exchange(true)) return;
  asio::post(impl_->io, [this] {
    boost::system::error_code ec;
    if (impl_->tcp_acceptor) impl_->tcp_acceptor->close(ec);
    if (impl_->unix_acceptor) impl_->unix_acceptor->close(ec);
    std::lock_guard lock(impl_->sessions_mutex);
    for (auto& weak : impl_->sessions) {
      if (auto s = weak.lock()) s->close();
    }
  });
  // Let the closes run, then end run(); handlers still pending are destroyed with the io_context, closing
  // whatever sockets remain.
  auto timer = std::make_shared<asio::steady_timer>(impl_->io, std::chrono::milliseconds(200));
  timer->async_wait([this, timer](const boost::system::error_code&) { impl_->io.stop(); });
}

}  // namespace kiln::daemon
