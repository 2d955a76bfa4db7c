// The C++ client of kilnd: one blocking connection, one request at a time (not thread-safe; use one Client per
// thread). Used by the `kiln` command line and the integration tests.
//
//   kiln::client::Client c("127.0.0.1:7700");        // or "unix:/run/kiln/kilnd.sock"; TLS: see Options::tls
//   c.hello(token);
//   auto reply = c.submit(job);
//   c.watch(reply.job_id(), [](const kiln::v1::JobEvent& e) { ... });
//   for (const auto& out : c.result(reply.job_id()).outputs()) save(out.name(), c.fetch(out.digest()));
//
// Errors: an answer of the server with an error is a ServerError; a broken, timed-out or garbled connection is a
// ConnectionError, after which the Client is closed (make a new one; uploads resume where they broke).
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "proto/kiln.pb.h"

namespace kiln::client {

// TLS to a kilnd started with --tls-cert (TCP only: a Unix socket stays plain). The server's certificate must chain
// to a CA in ca_file and name the host of the address (a DNS name, or an IP address in its subjectAltName).
struct TlsOptions {
  std::string ca_file;    // PEM CA certificates to trust; non-empty turns TLS on
  std::string cert_file;  // this client's certificate chain (PEM), for a server that requires one (--tls-client-ca)
  std::string key_file;   // its private key (PEM); needed with cert_file
};

struct Options {
  // Resolving and connecting, together.
  std::chrono::milliseconds connect_timeout{10'000};
  // For each response to arrive whole; while watching, for each event (the server repeats the latest event every
  // Limits.heartbeat_seconds, so keep this longer than that).
  std::chrono::milliseconds read_timeout{60'000};
  // For each request to be sent whole.
  std::chrono::milliseconds write_timeout{60'000};
  std::string client_name = "kiln-client 0.1.0";  // Hello.client, for the server's logs
  TlsOptions tls;
};

// The server answered a request with an error. Also raised with DATA_LOSS when fetched bytes fail verification.
class ServerError : public std::runtime_error {
 public:
  ServerError(v1::Error::Code code, const std::string& message, const std::string& field);
  v1::Error::Code code() const { return code_; }
  const std::string& message() const { return message_; }
  const std::string& field() const { return field_; }  // path of the offending field, may be empty

 private:
  v1::Error::Code code_;
  std::string message_, field_;
};

// No connection, a broken one, or a server that does not speak the protocol. The Client is closed afterwards.
class ConnectionError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
// TLS failed: the server does not speak it, its certificate is not trusted or not for this host, or it refused this
// client's certificate. The message says which and what to do.
class TlsError : public ConnectionError {
 public:
  using ConnectionError::ConnectionError;
};
// Connecting, sending or receiving took longer than its Options timeout.
class TimeoutError : public ConnectionError {
 public:
  using ConnectionError::ConnectionError;
};

// Called with the bytes done so far and the total.
using ProgressFn = std::function<void(std::uint64_t done, std::uint64_t total)>;

// The protocol's name of some bytes: SHA-256 in lowercase hex, and the size.
v1::Digest digest_of(std::string_view bytes);

class Client {
 public:
  // Connects to "HOST:PORT" (HOST a name, an IPv4 address or a bracketed IPv6 one) or "unix:PATH", with TLS's
  // handshake on TCP if options.tls.ca_file is set (within connect_timeout). Throws std::invalid_argument for a
  // malformed address or an unusable TLS file (naming it), ConnectionError (TimeoutError) if the server cannot be
  // reached or the handshake fails (saying why: a server without TLS, a certificate not trusted or not for this
  // host, a client certificate refused).
  explicit Client(const std::string& address, Options options = {});
  ~Client();
  Client(Client&&) noexcept;
  Client& operator=(Client&&) noexcept;

  // Must come first, and soon after connecting: kilnd closes a connection that has not said hello within its hello
  // deadline (5 s by default). Remembers the server's limits, which size the chunks of uploads and fetches. A refused
  // hello (ServerError, e.g. UNAUTHENTICATED) leaves the Client closed, as the server closes the connection.
  v1::HelloReply hello(const std::string& token);
  // The server's limits after hello(); the protocol's defaults before.
  const v1::Limits& limits() const;

  // The blobs among `digests` the server does not hold whole, with the bytes it holds of each.
  v1::BlobQueryReply query_blobs(const std::vector<v1::Digest>& digests);
  // Stores `bytes` on the server unless it already has them, resuming a broken upload from the server's offset, in
  // chunks of at most Limits.max_chunk_bytes. Returns their digest, by which jobs refer to them.
  v1::Digest upload_blob(std::string_view bytes, const ProgressFn& progress = {});
  // The same for a local file, read whole (an environment image, a face). Throws std::runtime_error naming the
  // file if it cannot be read or is larger than Limits.max_blob_bytes (checked before it is read).
  v1::Digest upload_file(const std::string& path, const ProgressFn& progress = {});

  // Throws std::invalid_argument naming the field, before anything is sent, if a string in `job` is not UTF-8.
  v1::SubmitReply submit(const v1::JobSpec& job, std::int32_t priority = 0, const std::string& idempotency_key = {});
  // Follows a job until it ends, calling on_event for each event (the first is the job's current state), and
  // returns the final one. Watching again after a broken connection re-attaches.
  v1::JobEvent watch(const std::string& job_id, const std::function<void(const v1::JobEvent&)>& on_event = {});
  // Following several jobs on this one connection (the protocol lets responses interleave): start_watch sends a
  // Watch and returns at once; next_watch_event returns the next event of any watch so started, in the order they
  // arrive, waiting up to Options::read_timeout (the server repeats each watch's latest event every
  // Limits.heartbeat_seconds). Other requests (result, fetch, submit) may be made meanwhile: the events that arrive
  // while they wait for their answer are kept for next_watch_event. A watch ends with its final event, or with an
  // error (WatchEvent::error set: an unknown job, a server shutting down). A broken connection forgets every watch:
  // start them again on a new Client (the first event is the job's current state, so nothing is missed).
  struct WatchEvent {
    std::string job_id;
    v1::JobEvent event;  // empty when error is set
    std::optional<v1::Error> error;
  };
  void start_watch(const std::string& job_id);
  WatchEvent next_watch_event();
  // Watches started and not yet ended.
  std::size_t watching() const;

  // The state the job is in afterwards.
  v1::JobState cancel(const std::string& job_id);
  v1::JobResult result(const std::string& job_id);

  // The bytes of a stored output, fetched in chunks and verified against the digest (ServerError DATA_LOSS if they
  // do not match).
  std::string fetch(const v1::Digest& digest, const ProgressFn& progress = {});
  // The same, handing each chunk to `sink` as it arrives: the bytes are only known good when fetch returns, so a
  // sink writing a file should write a temporary one and keep it only then.
  void fetch(const v1::Digest& digest, const std::function<void(std::string_view)>& sink,
             const ProgressFn& progress = {});

  v1::ServerStatus status();
  // Newest first; limit 0 means the server's default. JOB_STATE_UNSPECIFIED lists every state.
  v1::JobList list_jobs(std::uint32_t limit = 0, v1::JobState state = v1::JOB_STATE_UNSPECIFIED);

  bool is_open() const;
  void close();

 private:
  struct Impl;  // the Asio socket and the stream state, kept out of this header
  Impl& checked_impl();
  std::unique_ptr<Impl> impl_;
};

}  // namespace kiln::client
