#include "daemon/session.h"

#include <openssl/ssl.h>
#include <openssl/x509.h>
#include <boost/asio/ssl.hpp>

#include <array>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <deque>
#include <map>
#include <optional>
#include <type_traits>

#include "daemon/log.h"
#include "daemon/service.h"
#include "daemon/tls_context.h"
#include "proto/framing.h"
#include "proto/kiln.pb.h"

namespace kiln::daemon {

namespace asio = boost::asio;
using asio::ip::tcp;
using unix_socket = asio::local::stream_protocol;
using TlsStream = asio::ssl::stream<tcp::socket>;

namespace {

template <class Socket>
constexpr bool kIsTls = std::is_same_v<Socket, TlsStream>;

// The socket under the stream, to shut down and close (a TLS session ends without close_notify: kiln's frames carry
// their own lengths, so a truncated stream cannot pass for a complete answer).
template <class Socket>
auto& lowest_layer(Socket& s) {
  if constexpr (kIsTls<Socket>) {
    return s.lowest_layer();
  } else {
    return s;
  }
}

// The reason of a failed handshake for the log, with the certificate check's own reason when that is what failed.
std::string handshake_failure(TlsStream& stream, const boost::system::error_code& ec) {
  std::string why = ec.message();
  const long verify = SSL_get_verify_result(stream.native_handle());
  if (verify != X509_V_OK) why += " (client certificate: " + std::string(X509_verify_cert_error_string(verify)) + ")";
  return why;
}

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
      self->arm_deadline();  // before hello, it covers the TLS handshake too
      if constexpr (kIsTls<Socket>) {
        self->peek_first_bytes();
      } else {
        self->read();
      }
      self->schedule_heartbeat();
    });
  }

  void close() override {
    asio::post(strand_, [self = this->shared_from_this()] { self->shutdown(); });
  }

  // Refuses the connection at once (too many connections): one id-0 error, then close.
  void refuse(const std::string& message) override {
    asio::dispatch(strand_, [self = this->shared_from_this(), message] {
      if (!self->ready_) {
        log_line(self->subject(), "dropped before its TLS handshake ended: " + message);
        return self->shutdown();
      }
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

  // TLS: the first bytes are looked at, not taken, to tell a TLS client from one speaking plain kiln frames, which
  // would otherwise get only a TLS alert it cannot read.
  void peek_first_bytes() {
    if constexpr (kIsTls<Socket>) {
      socket_.next_layer().async_receive(
          asio::buffer(buffer_.data(), 2), tcp::socket::message_peek,
          asio::bind_executor(strand_, [self = this->shared_from_this()](auto ec, std::size_t n) {
            if (self->closed_) return;
            if (ec) return self->shutdown();  // gone before saying anything
            if (starts_tls_handshake(std::string_view(self->buffer_.data(), n))) return self->handshake();
            self->refuse_plain_client();
          }));
    }
  }

  void handshake() {
    if constexpr (kIsTls<Socket>) {
      socket_.async_handshake(
          asio::ssl::stream_base::server, asio::bind_executor(strand_, [self = this->shared_from_this()](auto ec) {
            if (self->closed_) return;  // the hello deadline ended it, and said so
            if (ec) {
              // Only this connection ends; the others are on their own strands and sockets.
              log_line(self->subject(), "TLS handshake failed: " + handshake_failure(self->socket_, ec));
              return self->shutdown();
            }
            self->ready_ = true;
            self->read();
          }));
    }
  }

  // A client that speaks plain kiln frames to the TLS listener gets one plain id-0 error saying so, which every kiln
  // client can read, then the connection closes. What it sent is read first: closing a socket with unread bytes
  // resets the connection, and the client could lose the answer.
  void refuse_plain_client() {
    if constexpr (kIsTls<Socket>) {
      const std::string why =
          "this kilnd accepts only TLS on TCP, and the client spoke without it: connect with TLS (kiln --tls-ca "
          "FILE, KILN_TLS_CA, or kiln.Client(tls_ca=...) in Python), trusting the CA that signed the server's "
          "certificate";
      log_line(subject(), "dropped: the client spoke plain TCP to the TLS listener");
      boost::system::error_code ignored;
      auto& raw = socket_.next_layer();
      const std::size_t available = std::min(raw.available(ignored), buffer_.size());
      if (available > 0) raw.read_some(asio::buffer(buffer_.data(), available), ignored);
      v1::Response r;
      Service::connection_error(r, v1::Error::FAILED_PRECONDITION, why);
      auto frame = std::make_shared<std::string>();
      proto::append_frame(r, *frame);
      asio::async_write(raw, asio::buffer(*frame),
                        asio::bind_executor(strand_, [self = this->shared_from_this(), frame](auto, std::size_t) {
                          self->shutdown();
                        }));
    }
  }

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
      // A TLS client may close without TLS's close_notify (stream_truncated): frames carry their lengths, so that
      // is an ordinary end, as eof is.
      if (ec != asio::error::eof && ec != asio::error::operation_aborted && ec != asio::ssl::error::stream_truncated) {
        log_line(subject(), "read failed: " + ec.message());
      }
      return shutdown();
    }
    if (sniff_tls_) {
      sniff_tls_ = false;
      if (starts_tls_handshake(std::string_view(buffer_.data(), n))) {
        return drop(
            "the client began a TLS handshake, but this kilnd serves TCP without TLS: connect without TLS, "
            "or start kilnd with --tls-cert and --tls-key",
            v1::Error::FAILED_PRECONDITION);
      }
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
        if (!self->ready_) {
          // Nothing can be said to a client whose TLS handshake has not ended: closing ends the handshake too.
          log_line(self->subject(), std::string("dropped: no TLS handshake and hello within the hello deadline (") +
                                        limit + " s after connecting)");
          return self->shutdown();
        }
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
    if (!ready_) return shutdown();  // mid-handshake: there is no channel to answer on
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
    auto& raw = lowest_layer(socket_);
    raw.shutdown(tcp::socket::shutdown_both, ignored);
    raw.close(ignored);
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
  // False until a TLS session's handshake succeeds: before, nothing can be written to the client.
  bool ready_ = !kIsTls<Socket>;
  // A plain TCP session looks at its first bytes for a TLS handshake, to tell such a client what is wrong.
  bool sniff_tls_ = std::is_same_v<Socket, tcp::socket>;
};

}  // namespace

std::shared_ptr<Session> make_session(asio::io_context& io, Service& service, ConnectionRegistry& registry,
                                      tcp::socket socket, asio::ssl::context* tls) {
  boost::system::error_code ec;
  const auto ep = socket.remote_endpoint(ec);
  std::string address = ec ? std::string() : ep.address().to_string();
  std::string peer = ec ? "tcp" : address + ":" + std::to_string(ep.port());
  if (tls) {
    // TLS writes its handshake and session tickets as several small records, each awaiting the one before with
    // Nagle's algorithm on: with the client's delayed acknowledgement, that stalled each handshake by ~40 ms.
    socket.set_option(tcp::no_delay(true), ec);
    return std::make_shared<SocketSession<TlsStream>>(io, service, registry, TlsStream(std::move(socket), *tls), false,
                                                      std::move(peer), std::move(address));
  }
  return std::make_shared<SocketSession<tcp::socket>>(io, service, registry, std::move(socket), false, std::move(peer),
                                                      std::move(address));
}

std::shared_ptr<Session> make_session(asio::io_context& io, Service& service, ConnectionRegistry& registry,
                                      unix_socket::socket socket) {
  return std::make_shared<SocketSession<unix_socket::socket>>(io, service, registry, std::move(socket), true,
                                                              "unix socket", std::string());
}

}  // namespace kiln::daemon
