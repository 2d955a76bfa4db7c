#include "client/lib/client.h"

#include <boost/asio/connect.hpp>
#include <boost/asio/generic/stream_protocol.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/local/stream_protocol.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/asio/write.hpp>

#include <openssl/ssl.h>
#include <openssl/x509.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <map>
#include <utility>

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>

#include "proto/digest.h"
#include "proto/framing.h"
#include "proto/text.h"

namespace kiln::client {

namespace asio = boost::asio;
using Clock = std::chrono::steady_clock;
using boost::system::error_code;

namespace {

constexpr std::size_t kReadChunkBytes = std::size_t{64} << 10;
// The largest response frame accepted whatever the server advertises, so a broken server cannot make the client
// buffer without bound.
constexpr std::size_t kMaxResponseFrameBytes = std::size_t{64} << 20;
// Room in a frame for the fields around a chunk's data.
constexpr std::size_t kFrameOverheadBytes = 1024;
// sockaddr_un.sun_path holds 108 bytes on Linux, including the terminating zero.
constexpr std::size_t kMaxUnixPathBytes = 107;
// Re-queries of an upload whose offset moved under it (another client uploading the same blob) in a row without the
// server's count growing, before giving up. While the count grows, whoever sends the chunks, the upload goes on:
// every uploader sends the same bytes, so any of them may append the next chunk.
constexpr int kMaxUploadRestarts = 3;

struct Address {
  bool unix_socket = false;
  std::string host, port, path;
};

Address parse_address(const std::string& address) {
  Address a;
  const auto bad = [&](const std::string& why) {
    return std::invalid_argument("server address \"" + address + "\": " + why);
  };
  if (address.rfind("unix:", 0) == 0) {
    a.unix_socket = true;
    a.path = address.substr(5);
    if (a.path.empty()) throw bad("no socket path after \"unix:\"");
    if (a.path.size() > kMaxUnixPathBytes)
      throw bad("socket path longer than " + std::to_string(kMaxUnixPathBytes) + " bytes");
    return a;
  }
  const auto colon = address.rfind(':');
  if (colon == std::string::npos) throw bad("expected HOST:PORT or unix:PATH");
  a.host = address.substr(0, colon);
  a.port = address.substr(colon + 1);
  if (a.host.size() >= 2 && a.host.front() == '[' && a.host.back() == ']') {
    a.host = a.host.substr(1, a.host.size() - 2);
  } else if (a.host.find(':') != std::string::npos) {
    throw bad("an IPv6 address goes in brackets, e.g. [::1]:7700");
  }
  if (a.host.empty()) throw bad("no host before the port");
  unsigned port = 0;
  const char* end = a.port.data() + a.port.size();
  const auto [ptr, ec] = std::from_chars(a.port.data(), end, port);
  if (a.port.empty() || ec != std::errc() || ptr != end || port < 1 || port > 65535)
    throw bad("port must be a number in [1, 65535]");
  return a;
}

std::string ms(std::chrono::milliseconds d) { return std::to_string(d.count()) + " ms"; }

bool contains(const std::string& text, const char* part) { return text.find(part) != std::string::npos; }

// The TLS context for `tls`: TLS 1.2 or newer, the server's certificate checked against ca_file, this client's
// certificate if given. Throws std::invalid_argument naming the file that cannot be used.
std::unique_ptr<asio::ssl::context> make_tls_context(const TlsOptions& tls) {
  if (tls.cert_file.empty() != tls.key_file.empty()) {
    throw std::invalid_argument(tls.cert_file.empty() ? "TLS client key " + tls.key_file + ": needs its certificate"
                                                      : "TLS client certificate " + tls.cert_file + ": needs its key");
  }
  auto ctx = std::make_unique<asio::ssl::context>(asio::ssl::context::tls_client);
  SSL_CTX_set_min_proto_version(ctx->native_handle(), TLS1_2_VERSION);
  ctx->set_options(asio::ssl::context::default_workarounds | asio::ssl::context::no_compression);
  const auto usable = [](const std::string& what, const std::string& path, const std::string& wanted) {
    std::ifstream in(path);
    if (!in) {
      throw std::invalid_argument(what + " " + path + ": cannot read it (" + std::strerror(errno) + "); give " +
                                  wanted);
    }
  };
  error_code ec;
  usable("TLS CA file", tls.ca_file, "the PEM certificate of the CA that signed the server's certificate");
  ctx->load_verify_file(tls.ca_file, ec);
  if (ec) {
    throw std::invalid_argument("TLS CA file " + tls.ca_file + ": holds no PEM certificate (" + ec.message() +
                                "); give the CA that signed the server's certificate");
  }
  ctx->set_verify_mode(asio::ssl::verify_peer);
  if (!tls.cert_file.empty()) {
    usable("TLS client certificate", tls.cert_file, "this client's certificate in PEM");
    usable("TLS client key", tls.key_file, "the client certificate's private key in PEM");
    ctx->use_certificate_chain_file(tls.cert_file, ec);
    if (ec) {
      throw std::invalid_argument("TLS client certificate " + tls.cert_file + ": not a PEM certificate (" +
                                  ec.message() + ")");
    }
    ctx->use_private_key_file(tls.key_file, asio::ssl::context::pem, ec);
    if (ec) {
      throw std::invalid_argument("TLS client key " + tls.key_file + ": not the unencrypted PEM key of " +
                                  tls.cert_file + " (" + ec.message() + ")");
    }
  }
  return ctx;
}

// The path of the first string field in `m` that is not UTF-8 ("job.lightmap.materials[2].name"), or "". protobuf
// serialises such a field (logging an error) but no peer can parse the frame: kilnd would drop the request.
std::string non_utf8_field(const google::protobuf::Message& m, const std::string& path) {
  using google::protobuf::FieldDescriptor;
  const google::protobuf::Reflection* r = m.GetReflection();
  std::vector<const FieldDescriptor*> fields;
  r->ListFields(m, &fields);
  for (const FieldDescriptor* f : fields) {
    const std::string at = path + "." + f->name();
    const int n = f->is_repeated() ? r->FieldSize(m, f) : 1;
    for (int i = 0; i < n; ++i) {
      const std::string item = f->is_repeated() ? at + "[" + std::to_string(i) + "]" : at;
      if (f->type() == FieldDescriptor::TYPE_STRING) {
        if (!proto::is_utf8(f->is_repeated() ? r->GetRepeatedString(m, f, i) : r->GetString(m, f))) return item;
      } else if (f->cpp_type() == FieldDescriptor::CPPTYPE_MESSAGE) {
        const std::string inner =
            non_utf8_field(f->is_repeated() ? r->GetRepeatedMessage(m, f, i) : r->GetMessage(m, f), item);
        if (!inner.empty()) return inner;
      }
    }
  }
  return "";
}

}  // namespace

ServerError::ServerError(v1::Error::Code code, const std::string& message, const std::string& field)
    : std::runtime_error((field.empty() ? "" : field + ": ") + message + " (" + v1::Error::Code_Name(code) + ")"),
      code_(code),
      message_(message),
      field_(field) {}

v1::Digest digest_of(std::string_view bytes) {
  v1::Digest d;
  d.set_sha256(proto::sha256_hex(bytes));
  d.set_size(bytes.size());
  return d;
}

struct Client::Impl {
  using TlsStream = asio::ssl::stream<asio::generic::stream_protocol::socket&>;

  Options options;
  asio::io_context io;
  asio::generic::stream_protocol::socket socket{io};
  // With TLS, reads and writes go through this stream over `socket`. Kept until the Impl goes, not reset on close:
  // an operation aborted by a timeout still refers to it until it has finished.
  std::unique_ptr<asio::ssl::context> tls_context;
  std::unique_ptr<TlsStream> tls;
  std::string address, host;
  proto::FrameDecoder decoder{proto::kDefaultMaxFrameBytes};
  std::vector<char> read_buffer = std::vector<char>(kReadChunkBytes);
  v1::Limits limits;
  std::uint64_t next_id = 1;
  bool open = false;
  // Watches started by start_watch, by request id, and the responses to them read while waiting for another answer.
  std::map<std::uint64_t, std::string> watches;
  std::deque<v1::Response> watch_responses;

  explicit Impl(Options o) : options(std::move(o)) {
    limits.set_max_frame_bytes(proto::kDefaultMaxFrameBytes);
    limits.set_max_chunk_bytes(proto::kDefaultMaxChunkBytes);
  }

  void close() {
    error_code ignored;
    socket.close(ignored);
    open = false;
    watches.clear();
    watch_responses.clear();
  }

  [[noreturn]] void fail(const std::string& why) {
    close();
    throw ConnectionError(why);
  }

  // Starts one asynchronous operation and runs it until it completes or the deadline passes. Asio's blocking calls
  // have no timeouts; this is how a blocking client gets them.
  template <typename Start>
  std::size_t wait(Start start, Clock::time_point deadline, std::chrono::milliseconds timeout, const char* what) {
    error_code result = asio::error::would_block;
    std::size_t bytes = 0;
    start([&](const error_code& ec, std::size_t n) {
      result = ec;
      bytes = n;
    });
    io.restart();
    io.run_until(deadline);
    if (result == asio::error::would_block) {
      // Still pending: abandon the operation, and with it the connection (its stream position is unknown now).
      close();
      io.restart();
      io.run();  // lets the aborted operation finish before its handler's captures go away
      throw TimeoutError(std::string(what) + " timed out after " + ms(timeout));
    }
    if (result) {
      if (result == asio::error::eof) fail(std::string(what) + ": the server closed the connection");
      if (tls &&
          (result.category() == asio::error::get_ssl_category() || result == asio::ssl::error::stream_truncated)) {
        const std::string why = std::string(what) + ": " + explain_tls(result);
        close();
        throw TlsError(why);
      }
      fail(std::string(what) + ": " + result.message());
    }
    return bytes;
  }

  // A TLS failure for people: what it means here and what to do. Under TLS 1.3 a server refusing this client's
  // certificate says so after the handshake, so this also explains the first read's error.
  std::string explain_tls(const error_code& ec) {
    const std::string reason = ec.message();
    if (ec == asio::ssl::error::stream_truncated || contains(reason, "wrong version number") ||
        contains(reason, "packet length too long") || contains(reason, "record layer failure")) {
      return "the server at " + address + " does not speak TLS (" + reason +
             "): start kilnd with --tls-cert and --tls-key, or connect without a TLS CA";
    }
    if (contains(reason, "certificate verify failed")) {
      const long verify = SSL_get_verify_result(tls->native_handle());
      if (verify == X509_V_ERR_HOSTNAME_MISMATCH || verify == X509_V_ERR_IP_ADDRESS_MISMATCH) {
        return "the server's certificate does not name the host " + host +
               ": connect by a name or address it was made for, or give the server a certificate for " + host;
      }
      return "the server's certificate is refused (" + std::string(X509_verify_cert_error_string(verify)) +
             "): it must be signed by a CA in " + options.tls.ca_file + " and name the host of " + address;
    }
    if (contains(reason, "alert certificate required") || contains(reason, "alert bad certificate") ||
        contains(reason, "alert unknown ca") || contains(reason, "alert handshake failure") ||
        contains(reason, "alert certificate unknown")) {
      return "the server refused the TLS connection (" + reason + ")" +
             (options.tls.cert_file.empty() ? "; it may require a client certificate: give one with its key"
                                            : "; it does not accept the client certificate " + options.tls.cert_file +
                                                  ": it must be signed by a CA in the server's --tls-client-ca");
    }
    return "TLS failed (" + reason + ")";
  }

  template <typename Handler>
  void start_write(const std::string& bytes, Handler handler) {
    if (tls) {
      asio::async_write(*tls, asio::buffer(bytes), handler);
    } else {
      asio::async_write(socket, asio::buffer(bytes), handler);
    }
  }
  template <typename Handler>
  void start_read(Handler handler) {
    if (tls) {
      tls->async_read_some(asio::buffer(read_buffer), handler);
    } else {
      socket.async_read_some(asio::buffer(read_buffer), handler);
    }
  }

  void connect(const std::string& server) {
    address = server;
    const Address a = parse_address(address);
    // TLS files are checked before connecting: a wrong path is the caller's mistake, not the network's.
    if (!a.unix_socket && !options.tls.ca_file.empty()) tls_context = make_tls_context(options.tls);
    const auto deadline = Clock::now() + options.connect_timeout;
    if (a.unix_socket) {
      const asio::generic::stream_protocol::endpoint endpoint{asio::local::stream_protocol::endpoint(a.path)};
      wait([&](auto handler) { socket.async_connect(endpoint, [handler](const error_code& ec) { handler(ec, 0); }); },
           deadline, options.connect_timeout, ("connecting to " + address).c_str());
    } else {
      // Name resolution has no timeout of its own in Asio (getaddrinfo cannot be interrupted); numeric addresses
      // and /etc/hosts names resolve at once.
      asio::ip::tcp::resolver resolver(io);
      error_code ec;
      const auto results = resolver.resolve(a.host, a.port, ec);
      if (ec) throw ConnectionError("cannot resolve \"" + a.host + "\": " + ec.message());
      std::vector<asio::generic::stream_protocol::endpoint> endpoints;
      for (const auto& r : results) endpoints.emplace_back(r.endpoint());
      const std::string what = "connecting to " + address;
      wait(
          [&](auto handler) {
            asio::async_connect(socket, endpoints,
                                [handler](const error_code& e, const auto& /*endpoint*/) { handler(e, 0); });
          },
          deadline, options.connect_timeout, what.c_str());
      // Requests are single small frames answered before the next: Nagle's delay would only add latency.
      socket.set_option(asio::ip::tcp::no_delay(true), ec);
      if (tls_context) handshake(a, deadline);
    }
    open = true;
  }

  // Within the connect deadline: the server's own hello deadline counts its handshake too.
  void handshake(const Address& a, Clock::time_point deadline) {
    tls = std::make_unique<TlsStream>(socket, *tls_context);
    host = a.host;
    error_code ec;
    asio::ip::make_address(a.host, ec);
    const bool is_address = !ec;
    // The certificate must name the host (an IP address must be in its subjectAltName), checked by OpenSSL with the
    // chain, so that a mismatch has its own verify result; names also go in SNI.
    SSL* ssl = tls->native_handle();
    if (is_address) {
      X509_VERIFY_PARAM_set1_ip_asc(SSL_get0_param(ssl), a.host.c_str());
    } else {
      SSL_set1_host(ssl, a.host.c_str());
      SSL_set_tlsext_host_name(ssl, a.host.c_str());
    }
    const std::string what = "TLS handshake with " + address;
    wait(
        [&](auto handler) {
          tls->async_handshake(asio::ssl::stream_base::client, [handler](const error_code& e) { handler(e, 0); });
        },
        deadline, options.connect_timeout, what.c_str());
  }

  void send(const v1::Request& request) {
    if (!open) throw ConnectionError("not connected");
    // A request the server would refuse as too large fails here, before anything is sent (FrameTooLarge).
    const std::string frame = proto::encode_frame(request, limits.max_frame_bytes());
    wait([&](auto handler) { start_write(frame, handler); }, Clock::now() + options.write_timeout,
         options.write_timeout, "sending a request");
  }

  v1::Response read_response(Clock::time_point deadline) {
    for (;;) {
      std::string_view payload;
      switch (decoder.next(payload)) {
        case proto::FrameDecoder::Status::frame: {
          v1::Response response;
          if (!proto::parse_frame(payload, response)) fail("the server sent a frame that is not a kiln.v1.Response");
          return response;
        }
        case proto::FrameDecoder::Status::error:
          fail("the server sent a malformed frame: " + decoder.error_message());
        case proto::FrameDecoder::Status::need_more:
          break;
      }
      const std::size_t n = wait([&](auto handler) { start_read(handler); }, deadline, options.read_timeout,
                                 "waiting for the server's answer");
      decoder.feed(std::string_view(read_buffer.data(), n));
    }
  }

  // The next response to request `id`, which must have the expected body; a server error becomes ServerError.
  v1::Response await(std::uint64_t id, v1::Response::BodyCase expected) {
    const auto deadline = Clock::now() + options.read_timeout;
    for (;;) {
      v1::Response response = read_response(deadline);
      if (response.id() == 0) {
        // A connection-level error: the server is closing the connection.
        close();
        if (response.has_error()) {
          throw ServerError(response.error().code(), response.error().message(), response.error().field());
        }
        throw ConnectionError("the server sent a response without a request id");
      }
      if (response.id() != id) {
        // Another watch's event is kept for next_watch_event; responses to an earlier request the caller abandoned
        // (a watch left by an exception) are skipped.
        if (watches.count(response.id())) watch_responses.push_back(std::move(response));
        continue;
      }
      if (response.has_error()) {
        throw ServerError(response.error().code(), response.error().message(), response.error().field());
      }
      if (response.body_case() != expected) {
        fail("the server answered request " + std::to_string(id) + " with the wrong kind of response (field " +
             std::to_string(response.body_case()) + ", expected " + std::to_string(expected) + ")");
      }
      return response;
    }
  }

  v1::Response call(v1::Request& request, v1::Response::BodyCase expected) {
    request.set_id(next_id++);
    send(request);
    return await(request.id(), expected);
  }

  // Data per BlobPut or FetchReply: the server's chunk limit, and small enough for its frame limit.
  std::size_t chunk_bytes() const {
    std::uint64_t chunk = limits.max_chunk_bytes();
    if (limits.max_frame_bytes() > 2 * kFrameOverheadBytes) {
      chunk = std::min<std::uint64_t>(chunk, limits.max_frame_bytes() - kFrameOverheadBytes);
    }
    return static_cast<std::size_t>(std::clamp<std::uint64_t>(chunk, 1, kMaxResponseFrameBytes - kFrameOverheadBytes));
  }
};

Client::Client(const std::string& address, Options options) : impl_(std::make_unique<Impl>(std::move(options))) {
  impl_->connect(address);
}
Client::~Client() = default;
Client::Client(Client&&) noexcept = default;
Client& Client::operator=(Client&&) noexcept = default;

bool Client::is_open() const { return impl_ && impl_->open; }
void Client::close() {
  if (impl_) impl_->close();
}
const v1::Limits& Client::limits() const {
  if (!impl_) throw ConnectionError("not connected");
  return impl_->limits;
}

Client::Impl& Client::checked_impl() {
  if (!impl_) throw ConnectionError("not connected");  // a moved-from Client
  return *impl_;
}

v1::HelloReply Client::hello(const std::string& token) {
  Impl& impl = checked_impl();
  v1::Request request;
  auto* hello = request.mutable_hello();
  hello->set_protocol_version(proto::kProtocolVersion);
  hello->set_token(token);
  hello->set_client(impl.options.client_name);
  v1::HelloReply reply;
  try {
    reply = impl.call(request, v1::Response::kHello).hello();
  } catch (const ServerError&) {
    impl.close();  // the server closes the connection after a failed hello
    throw;
  }
  if (reply.protocol_version() != proto::kProtocolVersion) {
    impl.fail("the server speaks protocol version " + std::to_string(reply.protocol_version()) + ", this client " +
              std::to_string(proto::kProtocolVersion));
  }
  impl.limits = reply.limits();
  // Zero means the server did not say: keep the protocol's defaults.
  if (impl.limits.max_frame_bytes() == 0) impl.limits.set_max_frame_bytes(proto::kDefaultMaxFrameBytes);
  if (impl.limits.max_chunk_bytes() == 0) impl.limits.set_max_chunk_bytes(proto::kDefaultMaxChunkBytes);
  impl.decoder.set_max_frame_bytes(std::clamp<std::uint64_t>(impl.limits.max_frame_bytes() + kFrameOverheadBytes,
                                                             proto::kDefaultMaxFrameBytes, kMaxResponseFrameBytes));
  return reply;
}

v1::BlobQueryReply Client::query_blobs(const std::vector<v1::Digest>& digests) {
  Impl& impl = checked_impl();
  v1::Request request;
  for (const auto& d : digests) *request.mutable_blob_query()->add_digests() = d;
  if (digests.empty()) request.mutable_blob_query();
  return impl.call(request, v1::Response::kBlobQuery).blob_query();
}

v1::Digest Client::upload_file(const std::string& path, const ProgressFn& progress) {
  std::error_code ec;
  const std::uint64_t size = std::filesystem::file_size(path, ec);
  if (ec) throw std::runtime_error("cannot read " + path + ": " + ec.message());
  if (size > limits().max_blob_bytes()) {
    throw std::runtime_error(path + " is " + std::to_string(size) + " bytes, more than the server's limit of " +
                             std::to_string(limits().max_blob_bytes()) + " bytes per blob");
  }
  std::ifstream in(path, std::ios::binary);
  std::string bytes(static_cast<std::size_t>(size), '\0');
  if (!in || !in.read(bytes.data(), static_cast<std::streamsize>(size)) || in.peek() != EOF) {
    throw std::runtime_error("cannot read " + path +
                             " whole: " + (in.bad() ? std::strerror(errno) : "it changed while being read"));
  }
  return upload_blob(bytes, progress);
}

v1::Digest Client::upload_blob(std::string_view bytes, const ProgressFn& progress) {
  Impl& impl = checked_impl();
  const v1::Digest digest = digest_of(bytes);
  const std::uint64_t total = bytes.size();
  const std::size_t chunk = impl.chunk_bytes();
  std::uint64_t furthest = 0;  // the most bytes the server held at any query
  for (int stalled = 0;;) {
    const v1::BlobQueryReply query = query_blobs({digest});
    const auto missing = std::find_if(query.missing().begin(), query.missing().end(), [&](const auto& m) {
      return m.digest().sha256() == digest.sha256() && m.digest().size() == digest.size();
    });
    if (missing == query.missing().end()) {
      if (progress) progress(total, total);
      return digest;
    }
    std::uint64_t offset = missing->received();
    if (offset > total) {
      impl.fail("the server holds " + std::to_string(offset) + " bytes of a " + std::to_string(total) + "-byte blob");
    }
    if (offset > furthest) furthest = offset, stalled = 0;
    try {
      for (;;) {
        if (progress) progress(offset, total);
        const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(chunk, total - offset));
        v1::Request request;
        auto* put = request.mutable_blob_put();
        *put->mutable_digest() = digest;
        put->set_offset(offset);
        put->set_data(bytes.data() + offset, n);
        const v1::BlobPutReply reply = impl.call(request, v1::Response::kBlobPut).blob_put();
        if (reply.complete()) {
          if (progress) progress(total, total);
          return digest;
        }
        // The server's count is the truth, but it has to move forward and cannot end without storing the blob.
        if (reply.received() <= offset || reply.received() >= total) {
          impl.fail("the server's upload offset went from " + std::to_string(offset) + " to " +
                    std::to_string(reply.received()) + " of " + std::to_string(total) + " bytes without storing it");
        }
        offset = reply.received();
      }
    } catch (const ServerError& e) {
      // Another upload of the same blob moved the server's offset: ask where it is now and go on from there.
      if (e.code() != v1::Error::FAILED_PRECONDITION || ++stalled > kMaxUploadRestarts) throw;
    }
  }
}

v1::SubmitReply Client::submit(const v1::JobSpec& job, std::int32_t priority, const std::string& idempotency_key) {
  Impl& impl = checked_impl();
  std::string field = non_utf8_field(job, "job");
  if (field.empty() && !proto::is_utf8(idempotency_key)) field = "idempotency_key";
  if (!field.empty()) {
    throw std::invalid_argument(field +
                                ": not valid UTF-8, which protobuf's string fields must be (kilnd could not "
                                "parse the request); nothing was sent");
  }
  v1::Request request;
  auto* submit = request.mutable_submit();
  *submit->mutable_job() = job;
  submit->set_priority(priority);
  submit->set_idempotency_key(idempotency_key);
  return impl.call(request, v1::Response::kSubmit).submit();
}

v1::JobEvent Client::watch(const std::string& job_id, const std::function<void(const v1::JobEvent&)>& on_event) {
  Impl& impl = checked_impl();
  v1::Request request;
  request.mutable_watch()->set_job_id(job_id);
  request.set_id(impl.next_id++);
  impl.send(request);
  for (;;) {
    // Each event gets the whole read timeout: a long bake is fine as long as the server keeps talking.
    v1::JobEvent event = impl.await(request.id(), v1::Response::kEvent).event();
    if (on_event) on_event(event);
    if (event.final()) return event;
  }
}

void Client::start_watch(const std::string& job_id) {
  Impl& impl = checked_impl();
  v1::Request request;
  request.mutable_watch()->set_job_id(job_id);
  request.set_id(impl.next_id++);
  impl.send(request);
  impl.watches.emplace(request.id(), job_id);
}

Client::WatchEvent Client::next_watch_event() {
  Impl& impl = checked_impl();
  if (impl.watches.empty()) throw std::logic_error("next_watch_event: no watch was started");
  v1::Response response;
  if (!impl.watch_responses.empty()) {
    response = std::move(impl.watch_responses.front());
    impl.watch_responses.pop_front();
  } else {
    const auto deadline = Clock::now() + impl.options.read_timeout;
    for (;;) {
      response = impl.read_response(deadline);
      if (response.id() == 0) {
        impl.close();
        if (response.has_error()) {
          throw ServerError(response.error().code(), response.error().message(), response.error().field());
        }
        throw ConnectionError("the server sent a response without a request id");
      }
      if (impl.watches.count(response.id())) break;
    }
  }
  const auto watch = impl.watches.find(response.id());
  WatchEvent out;
  out.job_id = watch->second;
  if (response.has_error()) {
    out.error = response.error();
    impl.watches.erase(watch);
    return out;
  }
  if (response.body_case() != v1::Response::kEvent) {
    impl.fail("the server answered the watch of job " + out.job_id + " with the wrong kind of response (field " +
              std::to_string(response.body_case()) + ")");
  }
  out.event = response.event();
  if (out.event.final()) impl.watches.erase(watch);
  return out;
}

std::size_t Client::watching() const { return impl_ ? impl_->watches.size() : 0; }

v1::JobState Client::cancel(const std::string& job_id) {
  Impl& impl = checked_impl();
  v1::Request request;
  request.mutable_cancel()->set_job_id(job_id);
  return impl.call(request, v1::Response::kCancel).cancel().state();
}

v1::JobResult Client::result(const std::string& job_id) {
  Impl& impl = checked_impl();
  v1::Request request;
  request.mutable_get_result()->set_job_id(job_id);
  return impl.call(request, v1::Response::kResult).result();
}

void Client::fetch(const v1::Digest& digest, const std::function<void(std::string_view)>& sink,
                   const ProgressFn& progress) {
  Impl& impl = checked_impl();
  if (!proto::is_valid_sha256_hex(digest.sha256())) {
    throw std::invalid_argument("fetch: digest \"" + digest.sha256() + "\" is not 64 lowercase hex digits");
  }
  const std::uint64_t total = digest.size();
  const std::size_t chunk = impl.chunk_bytes();
  proto::Sha256 hash;
  std::uint64_t offset = 0;
  for (;;) {
    if (progress) progress(offset, total);
    v1::Request request;
    auto* fetch = request.mutable_fetch();
    *fetch->mutable_digest() = digest;
    fetch->set_offset(offset);
    fetch->set_length(chunk);
    const v1::FetchReply reply = impl.call(request, v1::Response::kFetch).fetch();
    const std::string& data = reply.data();
    if (reply.offset() != offset) {
      impl.fail("the server answered a fetch at offset " + std::to_string(offset) + " with offset " +
                std::to_string(reply.offset()));
    }
    if (data.size() > chunk) {
      impl.fail("the server sent " + std::to_string(data.size()) + " bytes for a fetch of " + std::to_string(chunk));
    }
    if (data.size() > total - offset) {
      throw ServerError(v1::Error::DATA_LOSS,
                        "the server sent more than the " + std::to_string(total) + " bytes of blob " + digest.sha256(),
                        "digest.size");
    }
    if (data.empty() && !reply.eof()) impl.fail("the server sent no bytes of a fetch and no end either");
    hash.update(data);
    if (sink) sink(data);
    offset += data.size();
    if (reply.eof()) break;
  }
  if (offset != total) {
    throw ServerError(v1::Error::DATA_LOSS,
                      "blob " + digest.sha256() + " ended after " + std::to_string(offset) + " of " +
                          std::to_string(total) + " bytes",
                      "digest.size");
  }
  const std::string got = hash.finish();
  if (got != digest.sha256()) {
    throw ServerError(v1::Error::DATA_LOSS, "fetched bytes of blob " + digest.sha256() + " have SHA-256 " + got,
                      "digest.sha256");
  }
  if (progress) progress(total, total);
}

std::string Client::fetch(const v1::Digest& digest, const ProgressFn& progress) {
  std::string bytes;
  // The size comes from the server: reserve no more than a bounded amount on its word.
  bytes.reserve(static_cast<std::size_t>(std::min<std::uint64_t>(digest.size(), kMaxResponseFrameBytes)));
  fetch(
      digest, [&](std::string_view data) { bytes.append(data); }, progress);
  return bytes;
}

v1::ServerStatus Client::status() {
  Impl& impl = checked_impl();
  v1::Request request;
  request.mutable_status();
  return impl.call(request, v1::Response::kStatus).status();
}

v1::JobList Client::list_jobs(std::uint32_t limit, v1::JobState state) {
  Impl& impl = checked_impl();
  v1::Request request;
  request.mutable_list_jobs()->set_limit(limit);
  request.mutable_list_jobs()->set_state(state);
  return impl.call(request, v1::Response::kJobs).jobs();
}

}  // namespace kiln::client
