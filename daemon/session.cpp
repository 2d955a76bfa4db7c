#include "daemon/session.h"

#include <array>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <deque>
#include <map>
#include <optional>

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

std::atomic<uint64_t> next_session_id{1};

// A session over one kind of socket (TCP or a Unix socket), all of its work on one strand.
template <class Socket>
class SocketSession : public Session, public std::enable_shared_from_this<SocketSession<Socket>> {
 public:
  SocketSession(asio::io_context& io, Service& service, ConnectionRegistry& registry, Socket socket, bool is_unix,
                std::string peer, std::string address)
      : service_(service),
        registry_(registry),
        socket_(std::move(socket)),
        strand_(asio::make_strand(io)),
        deadline_(strand_),
        heartbeat_(strand_),
        answer_delay_(strand_),
        decoder_(service.config().max_frame_bytes) {
    info_.unix_socket = is_unix;
    info_.peer = std::move(peer);
    info_.address = std::move(address);
    info_.id = next_session_id++;
  }

  void start() override {
    service_.connection_opened();
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
  void refuse(const std::string& message) override {
    asio::dispatch(strand_, [self = this->shared_from_this(), message] {
      v1::Response r;
      Service::connection_error(r, v1::Error::RESOURCE_EXHAUSTED, message);
      self->send(r);
      self->closing_ = true;
    });
  }

  ~SocketSession() override {
    if (counted_) service_.connection_closed();
    registry_.closed(info_.id, promoted_);
  }

  void mark_counted() override { counted_ = true; }
  uint64_t id() const override { return info_.id; }

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
    if (!decoder_.feed(std::string_view(buffer_.data(), n))) return drop_for_decoder_error();
    std::string_view payload;
    proto::FrameDecoder::Status status;
    while (!closing_ && (status = decoder_.next(payload)) == proto::FrameDecoder::Status::frame) {
      v1::Request request;
      if (!proto::parse_frame(payload, request)) {
        return drop("a frame is not a valid kiln.v1.Request", v1::Error::INVALID_ARGUMENT);
      }
      // Id 0 is reserved for connection-level errors, so a request that uses it cannot be answered by id: it is a
      // broken client, treated like a bad frame.
      if (request.id() == 0)
        return drop("a request has id 0; request ids must be nonzero", v1::Error::INVALID_ARGUMENT);
      dispatch(request);
    }
    if (decoder_.error() != proto::FrameDecoder::Error::none) return drop_for_decoder_error();
    arm_deadline();
    read();
  }

  void dispatch(const v1::Request& request) {
    v1::Response response;
    store::Subscription subscription;
    std::weak_ptr<SocketSession> weak = this->shared_from_this();
    auto on_event = [weak, strand = strand_, id = request.id()](const v1::Response& event) {
      asio::post(strand, [weak, event, id] {
        if (auto self = weak.lock()) self->send_event(id, event);
      });
    };
    service_.handle(info_, request, response, on_event, &subscription);
    if (request.body_case() == v1::Request::kHello) {
      if (response.has_error()) return refuse_hello(response);
      if (!promoted_ && !registry_.promote(info_.id)) {
        // Past max_connections: the hello is answered with the limit, and the connection closes.
        info_.authenticated = false;
        response.clear_body();
        response.mutable_error()->set_code(v1::Error::RESOURCE_EXHAUSTED);
        response.mutable_error()->set_message("the server has " + std::to_string(service_.config().max_connections) +
                                              " connections that said hello, its limit (max_connections); try "
                                              "again later");
        closing_ = true;
        return send(response);
      }
      promoted_ = true;
    }
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
      proto::append_frame(response, frame, service_.config().max_frame_bytes);
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
                      asio::bind_executor(
                          strand_, [self = this->shared_from_this()](auto ec, std::size_t) { self->on_written(ec); }));
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
        schedule_heartbeat();             // the watch may be due already if its write was slow
      }
    }
    if (!writes_.empty()) return write_next();
    if (closing_) return shutdown();
    read();  // resumes reading if backpressure had paused it
  }

  // Deadlines: a frame that has started must be finished within frame_deadline_seconds; otherwise the connection
  // may stay idle for idle_timeout_seconds (watches count as activity). Before its Hello succeeds, a connection
  // has hello_deadline_seconds from its start in all, whatever it sends: idle sockets that never authenticate
  // cannot hold the server's connections for long.
  void arm_deadline() {
    const Config& c = service_.config();
    const auto seconds = [](double s) {
      return std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(s));
    };
    const bool mid = decoder_.mid_frame();
    if (mid && !frame_started_) frame_started_ = std::chrono::steady_clock::now();
    if (!mid) frame_started_.reset();
    const auto now = std::chrono::steady_clock::now();
    auto expiry = mid ? *frame_started_ + seconds(c.frame_deadline_seconds) : now + seconds(c.idle_timeout_seconds);
    const bool before_hello = !info_.authenticated;
    if (before_hello) expiry = std::min(expiry, started_ + seconds(c.hello_deadline_seconds));
    deadline_.expires_at(expiry);
    deadline_.async_wait([self = this->shared_from_this(), mid, before_hello](const boost::system::error_code& ec) {
      if (ec || self->closed_) return;
      if (before_hello) {
        if (self->info_.authenticated) return self->arm_deadline();  // said hello meanwhile: the usual deadlines
        char limit[32];
        std::snprintf(limit, sizeof limit, "%g", self->service_.config().hello_deadline_seconds);
        return self->drop(std::string("no successful hello within the hello deadline (") + limit +
                              " s after connecting); connect again and say hello first",
                          v1::Error::DEADLINE_EXCEEDED);
      }
      if (!self->watches_.empty() && !mid) return self->arm_deadline();  // an open watch is not idleness
      self->drop(mid ? "a frame did not arrive whole within the frame deadline"
                     : "the connection was idle longer than the idle timeout",
                 v1::Error::DEADLINE_EXCEEDED);
    });
  }

  // Repeats each watch's latest event when nothing was sent for it within the heartbeat period. The timer wakes
  // when the first watch falls due, not on a fixed grid: a grid tick just short of a watch's due time would skip it
  // and leave a gap of nearly two periods, breaking HelloReply's promise. A watch whose last event is still being
  // written (awaiting_ready) needs no repeat: the client is not reading.
  void schedule_heartbeat() {
    const auto period = std::chrono::seconds(service_.config().heartbeat_seconds);
    auto wake = std::chrono::steady_clock::now() + period;
    for (const auto& [id, w] : watches_) {
      if (!w.awaiting_ready) wake = std::min(wake, w.last_sent + period);
    }
    heartbeat_.expires_at(wake);
    heartbeat_.async_wait([self = this->shared_from_this(), period](const boost::system::error_code& ec) {
      if (ec || self->closed_) return;
      const auto now = std::chrono::steady_clock::now();
      for (auto& [id, w] : self->watches_) {
        if (now - w.last_sent >= period && !w.awaiting_ready) {
          w.last_sent = now;
          self->send(w.last);
        }
      }
      self->schedule_heartbeat();
    });
  }

  // A failed Hello: nothing more is read, the answer waits as long as the service says (a peer guessing tokens gets
  // slower and slower answers), then the connection closes.
  void refuse_hello(const v1::Response& response) {
    closing_ = true;
    const auto delay = service_.hello_failed(info_);
    if (delay.count() == 0) return send(response);
    answer_delay_.expires_after(delay);
    answer_delay_.async_wait([self = this->shared_from_this(), response](const boost::system::error_code& ec) {
      if (ec || self->closed_) return;
      self->send(response);
    });
  }

  // A frame too large is a limit of the server; a malformed length is the client's error.
  void drop_for_decoder_error() {
    drop(decoder_.error_message(), decoder_.error() == proto::FrameDecoder::Error::frame_too_large
                                       ? v1::Error::RESOURCE_EXHAUSTED
                                       : v1::Error::INVALID_ARGUMENT);
  }

  // Sends one id-0 error with `code`, then closes: every id-0 response is followed by the end of the connection.
  void drop(const std::string& why, int code) {
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
    answer_delay_.cancel();
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

  Service& service_;
  ConnectionRegistry& registry_;
  Socket socket_;
  asio::strand<asio::io_context::executor_type> strand_;
  asio::steady_timer deadline_, heartbeat_, answer_delay_;
  proto::FrameDecoder decoder_;
  SessionInfo info_;
  std::array<char, kReadChunk> buffer_{};
  std::deque<Pending> writes_;
  std::size_t pending_bytes_ = 0;
  std::map<uint64_t, Watch> watches_;
  std::optional<std::chrono::steady_clock::time_point> frame_started_;
  const std::chrono::steady_clock::time_point started_ = std::chrono::steady_clock::now();
  bool reading_ = false, closing_ = false, closed_ = false, counted_ = false, promoted_ = false;
};

}  // namespace

std::shared_ptr<Session> make_session(asio::io_context& io, Service& service, ConnectionRegistry& registry,
                                      tcp::socket socket) {
  boost::system::error_code ec;
  const auto ep = socket.remote_endpoint(ec);
  std::string address = ec ? std::string() : ep.address().to_string();
  std::string peer = ec ? "tcp" : address + ":" + std::to_string(ep.port());
  return std::make_shared<SocketSession<tcp::socket>>(io, service, registry, std::move(socket), false, std::move(peer),
                                                      std::move(address));
}

std::shared_ptr<Session> make_session(asio::io_context& io, Service& service, ConnectionRegistry& registry,
                                      unix_socket::socket socket) {
  return std::make_shared<SocketSession<unix_socket::socket>>(io, service, registry, std::move(socket), true,
                                                              "unix socket", std::string());
}

}  // namespace kiln::daemon
