#include "daemon/server.h"

// Boost 1.74's Asio uses std::exchange without including <utility> itself.
#include <utility>

#include <boost/asio.hpp>

#include <sys/stat.h>

#include <atomic>
#include <deque>
#include <filesystem>
#include <map>
#include <mutex>
#include <set>
#include <thread>

#include "daemon/log.h"
#include "daemon/service.h"
#include "proto/framing.h"
#include "proto/kiln.pb.h"

namespace kiln::daemon {

namespace asio = boost::asio;
using asio::ip::tcp;
using unix_socket = asio::local::stream_protocol;

namespace {

constexpr std::size_t kReadChunk = 64 * 1024;
// Past this many bytes of answers not yet written, the session stops reading requests until the client catches up.
constexpr std::size_t kMaxPendingWrite = 8 * 1024 * 1024;
constexpr auto kHeartbeat = std::chrono::seconds(10);

std::atomic<uint64_t> next_session_id{1};

}  // namespace

// What the server tracks of its sessions, so stop() can close them.
class SessionBase {
 public:
  virtual ~SessionBase() = default;
  virtual void close() = 0;
};

struct Server::Impl {
  Service& service;
  asio::io_context io;
  std::optional<tcp::acceptor> tcp_acceptor;
  std::optional<unix_socket::acceptor> unix_acceptor;
  std::string unix_path;
  std::mutex sessions_mutex;
  std::set<std::weak_ptr<SessionBase>, std::owner_less<std::weak_ptr<SessionBase>>> sessions;
  std::atomic<bool> stopping{false};

  explicit Impl(Service& s) : service(s) {}
  template <class Acceptor>
  void accept(Acceptor& acceptor, bool is_unix);
};

namespace {

template <class Socket>
class Session : public SessionBase, public std::enable_shared_from_this<Session<Socket>> {
 public:
  Session(Server::Impl& server, Socket socket, bool is_unix, std::string peer)
      : server_(server),
        socket_(std::move(socket)),
        strand_(asio::make_strand(server.io)),
        deadline_(strand_),
        heartbeat_(strand_),
        decoder_(server.service.config().max_frame_bytes) {
    info_.unix_socket = is_unix;
    info_.peer = std::move(peer);
    info_.id = next_session_id++;
  }

  void start() {
    server_.service.connection_opened();
    asio::dispatch(strand_, [self = this->shared_from_this()] {
      self->arm_deadline();
      self->read();
      self->schedule_heartbeat();
    });
  }

  void close() override {
    asio::post(strand_, [self = this->shared_from_this()] { self->shutdown(); });
  }

  // Refuses the connection at once (too many connections): one id-0 error, then close.
  void refuse(const std::string& message) {
    asio::dispatch(strand_, [self = this->shared_from_this(), message] {
      v1::Response r;
      Service::connection_error(r, v1::Error::RESOURCE_EXHAUSTED, message);
      self->send(r);
      self->closing_ = true;
    });
  }

  ~Session() override {
    if (counted_) server_.service.connection_closed();
  }

  void mark_counted() { counted_ = true; }

 private:
  std::string subject() const { return "connection " + std::to_string(info_.id) + " (" + info_.peer + ")"; }

  void read() {
    if (closed_ || reading_ || closing_) return;
    if (pending_bytes_ > kMaxPendingWrite) return;  // backpressure: resumed when writes drain
    reading_ = true;
    socket_.async_read_some(asio::buffer(buffer_),
                            asio::bind_executor(strand_, [self = this->shared_from_this()](auto ec, std::size_t n) {
                              self->reading_ = false;
                              self->on_read(ec, n);
                            }));
  }

  void on_read(const boost::system::error_code& ec, std::size_t n) {
    if (closed_) return;
    if (ec) {
      if (ec != asio::error::eof && ec != asio::error::operation_aborted) {
        log_line(subject(), "read failed: " + ec.message());
      }
      return shutdown();
    }
    if (!decoder_.feed(std::string_view(buffer_.data(), n))) return drop(decoder_.error_message());
    std::string_view payload;
    proto::FrameDecoder::Status status;
    while (!closing_ && (status = decoder_.next(payload)) == proto::FrameDecoder::Status::frame) {
      v1::Request request;
      if (!proto::parse_frame(payload, request)) {
        return drop("a frame is not a valid kiln.v1.Request");
      }
      dispatch(request);
    }
    if (decoder_.error() != proto::FrameDecoder::Error::none) return drop(decoder_.error_message());
    arm_deadline();
    read();
  }

  void dispatch(const v1::Request& request) {
    v1::Response response;
    store::Subscription subscription;
    std::weak_ptr<Session> weak = this->shared_from_this();
    auto on_event = [weak, strand = strand_, id = request.id()](const v1::Response& event) {
      asio::post(strand, [weak, event, id] {
        if (auto self = weak.lock()) self->send_event(id, event);
      });
    };
    server_.service.handle(info_, request, response, on_event, &subscription);
    if (response.has_event()) {
      Watch& w = watches_[request.id()];
      response.mutable_event()->set_sequence(++w.sequence);
      w.last = response;
      w.last_sent = std::chrono::steady_clock::now();
      w.awaiting_ready = static_cast<bool>(subscription);
      if (subscription && !response.event().final()) {
        w.subscription = std::move(subscription);
      } else {
        watches_.erase(request.id());
      }
    }
    send(response, request.id());
  }

  void send_event(uint64_t request_id, v1::Response event) {
    auto it = watches_.find(request_id);
    if (it == watches_.end() || closed_) return;
    Watch& w = it->second;
    event.mutable_event()->set_sequence(++w.sequence);
    w.last = event;
    w.last_sent = std::chrono::steady_clock::now();
    w.awaiting_ready = true;
    const bool final = event.event().final();
    send(event, request_id);
    if (final) watches_.erase(it);
  }

  // Queues one response; `watch_id` names the watch whose subscription is told ready() once it is written.
  void send(const v1::Response& response, uint64_t watch_id = 0) {
    std::string frame;
    try {
      proto::append_frame(response, frame, server_.service.config().max_frame_bytes);
    } catch (const proto::FrameTooLarge&) {
      v1::Response r;
      r.set_id(response.id());
      r.mutable_error()->set_code(v1::Error::INTERNAL);
      r.mutable_error()->set_message("the answer exceeds the frame limit; ask for less (e.g. a smaller fetch)");
      proto::append_frame(r, frame);
    }
    pending_bytes_ += frame.size();
    writes_.push_back({std::move(frame), watch_id});
    if (writes_.size() == 1) write_next();
  }

  void write_next() {
    if (writes_.empty() || closed_) return;
    asio::async_write(socket_, asio::buffer(writes_.front().bytes),
                      asio::bind_executor(strand_, [self = this->shared_from_this()](auto ec, std::size_t) {
                        self->on_written(ec);
                      }));
  }

  void on_written(const boost::system::error_code& ec) {
    if (closed_) return;
    if (ec) return shutdown();
    Pending done = std::move(writes_.front());
    writes_.pop_front();
    pending_bytes_ -= done.bytes.size();
    if (done.watch_id != 0) {
      auto it = watches_.find(done.watch_id);
      if (it != watches_.end() && it->second.awaiting_ready && it->second.subscription) {
        it->second.awaiting_ready = false;
        it->second.subscription.ready();  // may deliver the latest progress at once (posted to this strand)
      }
    }
    if (!writes_.empty()) return write_next();
    if (closing_) return shutdown();
    read();  // resumes reading if backpressure had paused it
  }

  // Deadlines: a frame that has started must be finished within frame_deadline_seconds; otherwise the connection
  // may stay idle for idle_timeout_seconds (watches count as activity).
  void arm_deadline() {
    const Config& c = server_.service.config();
    const bool mid = decoder_.mid_frame();
    if (mid && !frame_started_) frame_started_ = std::chrono::steady_clock::now();
    if (!mid) frame_started_.reset();
    const auto now = std::chrono::steady_clock::now();
    const auto expiry = mid ? *frame_started_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                   std::chrono::duration<double>(c.frame_deadline_seconds))
                            : now + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                        std::chrono::duration<double>(c.idle_timeout_seconds));
    deadline_.expires_at(expiry);
    deadline_.async_wait([self = this->shared_from_this(), mid](const boost::system::error_code& ec) {
      if (ec || self->closed_) return;
      if (!self->watches_.empty() && !mid) return self->arm_deadline();  // an open watch is not idleness
      self->drop(mid ? "a frame did not arrive whole within the frame deadline"
                     : "the connection was idle longer than the idle timeout",
                 v1::Error::DEADLINE_EXCEEDED);
    });
  }

  // Repeats each watch's latest event when nothing was sent for it within the heartbeat period.
  void schedule_heartbeat() {
    heartbeat_.expires_after(kHeartbeat);
    heartbeat_.async_wait([self = this->shared_from_this()](const boost::system::error_code& ec) {
      if (ec || self->closed_) return;
      const auto now = std::chrono::steady_clock::now();
      for (auto& [id, w] : self->watches_) {
        if (now - w.last_sent >= kHeartbeat && !w.awaiting_ready) {
          w.last_sent = now;
          self->send(w.last);
        }
      }
      self->schedule_heartbeat();
    });
  }

  void drop(const std::string& why, int code = v1::Error::RESOURCE_EXHAUSTED) {
    if (closing_ || closed_) return;
    log_line(subject(), "dropped: " + why);
    v1::Response r;
    Service::connection_error(r, code, why);
    closing_ = true;
    send(r);  // written, then the connection closes
  }

  void shutdown() {
    if (closed_) return;
    closed_ = true;
    watches_.clear();  // unsubscribes
    boost::system::error_code ignored;
    socket_.shutdown(Socket::shutdown_both, ignored);
    socket_.close(ignored);
    deadline_.cancel();
    heartbeat_.cancel();
  }

  struct Watch {
    store::Subscription subscription;
    v1::Response last;
    uint64_t sequence = 0;
    std::chrono::steady_clock::time_point last_sent;
    bool awaiting_ready = false;
  };
  struct Pending {
    std::string bytes;
    uint64_t watch_id = 0;
  };

  Server::Impl& server_;
  Socket socket_;
  asio::strand<asio::io_context::executor_type> strand_;
  asio::steady_timer deadline_, heartbeat_;
  proto::FrameDecoder decoder_;
  SessionInfo info_;
  std::array<char, kReadChunk> buffer_{};
  std::deque<Pending> writes_;
  std::size_t pending_bytes_ = 0;
  std::map<uint64_t, Watch> watches_;
  std::optional<std::chrono::steady_clock::time_point> frame_started_;
  bool reading_ = false, closing_ = false, closed_ = false, counted_ = false;
};

std::string peer_of(const tcp::socket& s) {
  boost::system::error_code ec;
  const auto ep = s.remote_endpoint(ec);
  return ec ? "tcp" : ep.address().to_string() + ":" + std::to_string(ep.port());
}
std::string peer_of(const unix_socket::socket&) { return "unix socket"; }

}  // namespace

template <class Acceptor>
void Server::Impl::accept(Acceptor& acceptor, bool is_unix) {
  acceptor.async_accept(asio::make_strand(io), [this, &acceptor, is_unix](const boost::system::error_code& ec,
                                                                          typename Acceptor::protocol_type::socket s) {
    if (stopping) return;
    if (!ec) {
      using SocketT = typename Acceptor::protocol_type::socket;
      auto session = std::make_shared<Session<SocketT>>(*this, std::move(s), is_unix, peer_of(s));
      std::size_t open;
      {
        std::lock_guard lock(sessions_mutex);
        for (auto it = sessions.begin(); it != sessions.end();) it = it->expired() ? sessions.erase(it) : ++it;
        open = sessions.size();
        sessions.insert(session);
      }
      session->mark_counted();
      session->start();
      if (open >= service.config().max_connections) {
        session->refuse("the server has " + std::to_string(open) + " connections, its limit; try again later");
      }
    } else if (ec != asio::error::operation_aborted) {
      log_line("listener", "accept failed: " + ec.message());
    }
    accept(acceptor, is_unix);
  });
}

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
    if (ec || results.empty()) throw std::runtime_error("--listen " + c.listen + ": cannot resolve (" + ec.message() + ")");
    const tcp::endpoint ep = results.begin()->endpoint();
    tcp::acceptor a(impl_->io);
    a.open(ep.protocol(), ec);
    if (!ec) a.set_option(tcp::acceptor::reuse_address(true), ec);
    if (!ec) a.bind(ep, ec);
    if (!ec) a.listen(asio::socket_base::max_listen_connections, ec);
    if (ec) throw std::runtime_error("--listen " + c.listen + ": cannot listen (" + ec.message() + ")");
    impl_->tcp_acceptor.emplace(std::move(a));
    impl_->accept(*impl_->tcp_acceptor, false);
  }
  if (!c.socket.empty()) {
    // A socket file left by a previous run that died would make bind fail; nobody listens on it any more.
    std::error_code fs_ec;
    if (std::filesystem::is_socket(c.socket, fs_ec)) std::filesystem::remove(c.socket, fs_ec);
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
    impl_->accept(*impl_->unix_acceptor, true);
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
