// The client library against a small fake server in this file (the real kilnd is tested by the integration tests):
// chunked and resumed uploads, verified fetches, watches, error mapping, timeouts and garbled answers.
#include "client/lib/client.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "proto/digest.h"
#include "proto/framing.h"

namespace kiln::client {
namespace {

// One accepted connection of the fake server.
struct Peer {
  int fd;
  void send_raw(std::string_view bytes) const {
    while (!bytes.empty()) {
      const ssize_t n = ::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL);
      if (n <= 0) return;  // the client went away; the test will notice on its side
      bytes.remove_prefix(static_cast<std::size_t>(n));
    }
  }
  void send(const v1::Response& response) const { send_raw(proto::encode_frame(response)); }
  void send_error(std::uint64_t id, v1::Error::Code code, const std::string& message,
                  const std::string& field = {}) const {
    v1::Response r;
    r.set_id(id);
    r.mutable_error()->set_code(code);
    r.mutable_error()->set_message(message);
    r.mutable_error()->set_field(field);
    send(r);
  }
};

// Listens on a loopback port (or a Unix socket), serves one connection at a time on its own thread and hands each
// request to the handler, which answers through the Peer and returns false to drop the connection.
class FakeServer {
 public:
  using Handler = std::function<bool(const v1::Request&, const Peer&)>;

  explicit FakeServer(Handler handler, const std::string& unix_path = {}) : handler_(std::move(handler)) {
    if (unix_path.empty()) {
      listen_fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
      sockaddr_in a{};
      a.sin_family = AF_INET;
      a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
      a.sin_port = 0;  // any free port
      bind_and_listen(reinterpret_cast<sockaddr*>(&a), sizeof a);
      socklen_t len = sizeof a;
      ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&a), &len);
      address_ = "127.0.0.1:" + std::to_string(ntohs(a.sin_port));
    } else {
      listen_fd_ = ::socket(AF_UNIX, SOCK_STREAM, 0);
      sockaddr_un a{};
      a.sun_family = AF_UNIX;
      unix_path.copy(a.sun_path, sizeof a.sun_path - 1);
      bind_and_listen(reinterpret_cast<sockaddr*>(&a), sizeof a);
      unix_path_ = unix_path;
      address_ = "unix:" + unix_path;
    }
    thread_ = std::thread([this] { run(); });
  }
  ~FakeServer() {
    stop_ = true;
    thread_.join();
    ::close(listen_fd_);
    if (!unix_path_.empty()) ::unlink(unix_path_.c_str());
  }
  const std::string& address() const { return address_; }
  // The largest request frame payload received.
  std::size_t largest_frame() const { return largest_frame_; }

 private:
  void bind_and_listen(sockaddr* a, socklen_t len) {
    if (::bind(listen_fd_, a, len) != 0 || ::listen(listen_fd_, 8) != 0) throw std::runtime_error("fake server: bind");
  }
  // Polls with a short period so that the destructor's stop flag is seen promptly.
  bool readable(int fd) const {
    pollfd p{fd, POLLIN, 0};
    return ::poll(&p, 1, 20) > 0;
  }
  void run() {
    while (!stop_) {
      if (!readable(listen_fd_)) continue;
      const int fd = ::accept(listen_fd_, nullptr, nullptr);
      if (fd < 0) continue;
      serve(fd);
      ::close(fd);
    }
  }
  void serve(int fd) {
    proto::FrameDecoder decoder;
    std::vector<char> buffer(64 << 10);
    while (!stop_) {
      if (!readable(fd)) continue;
      const ssize_t n = ::read(fd, buffer.data(), buffer.size());
      if (n <= 0) return;
      decoder.feed(std::string_view(buffer.data(), static_cast<std::size_t>(n)));
      std::string_view payload;
      proto::FrameDecoder::Status status;
      while ((status = decoder.next(payload)) == proto::FrameDecoder::Status::frame) {
        largest_frame_ = std::max<std::size_t>(largest_frame_, payload.size());
        v1::Request request;
        if (!proto::parse_frame(payload, request)) return;
        if (!handler_(request, Peer{fd})) return;
      }
      if (status == proto::FrameDecoder::Status::error) return;
    }
  }

  Handler handler_;
  int listen_fd_ = -1;
  std::string address_, unix_path_;
  std::atomic<bool> stop_{false};
  std::atomic<std::size_t> largest_frame_{0};
  std::thread thread_;
};

// The blob side of kilnd, as the protocol describes it: partial uploads kept across connections, offsets checked,
// the digest verified when the last byte arrives.
struct FakeBlobs {
  std::mutex mutex;
  std::uint64_t max_chunk = 1000;
  std::uint64_t max_frame = proto::kDefaultMaxFrameBytes;
  std::map<std::string, std::string> partial, stored;
  std::vector<std::pair<std::uint64_t, std::size_t>> puts;  // offset and size of every chunk taken
  int drop_after_puts = -1;  // take this many chunks' data, then drop the connection without answering
  std::string token;

  bool handle(const v1::Request& request, const Peer& peer) {
    std::lock_guard lock(mutex);
    v1::Response response;
    response.set_id(request.id());
    switch (request.body_case()) {
      case v1::Request::kHello: {
        token = request.hello().token();
        auto* hello = response.mutable_hello();
        hello->set_protocol_version(proto::kProtocolVersion);
        hello->set_server_version("fake 0");
        hello->mutable_limits()->set_max_chunk_bytes(max_chunk);
        hello->mutable_limits()->set_max_frame_bytes(max_frame);
        hello->add_job_types("material");
        break;
      }
      case v1::Request::kBlobQuery: {
        auto* reply = response.mutable_blob_query();
        for (const auto& d : request.blob_query().digests()) {
          if (stored.count(d.sha256())) continue;
          auto* missing = reply->add_missing();
          *missing->mutable_digest() = d;
          missing->set_received(partial[d.sha256()].size());
        }
        break;
      }
      case v1::Request::kBlobPut: {
        const auto& put = request.blob_put();
        const std::string& sha = put.digest().sha256();
        std::string& held = partial[sha];
        if (put.offset() != held.size()) {
          peer.send_error(request.id(), v1::Error::FAILED_PRECONDITION,
                          "offset " + std::to_string(put.offset()) + " is not " + std::to_string(held.size()),
                          "offset");
          return true;
        }
        if (put.data().size() > max_chunk || held.size() + put.data().size() > put.digest().size()) {
          peer.send_error(request.id(), v1::Error::INVALID_ARGUMENT, "chunk too large", "data");
          return true;
        }
        held += put.data();
        puts.emplace_back(put.offset(), put.data().size());
        if (static_cast<int>(puts.size()) == drop_after_puts) return false;
        auto* reply = response.mutable_blob_put();
        reply->set_received(held.size());
        if (held.size() == put.digest().size()) {
          if (proto::sha256_hex(held) != sha) {
            partial.erase(sha);
            peer.send_error(request.id(), v1::Error::DATA_LOSS, "bytes do not match the digest", "digest.sha256");
            return true;
          }
          stored[sha] = held;
          partial.erase(sha);
          reply->set_complete(true);
        }
        break;
      }
      case v1::Request::kFetch: {
        const auto& f = request.fetch();
        const auto it = stored.find(f.digest().sha256());
        if (it == stored.end()) {
          peer.send_error(request.id(), v1::Error::NOT_FOUND, "no such blob", "digest");
          return true;
        }
        const std::uint64_t length = f.length() == 0 ? max_chunk : std::min<std::uint64_t>(f.length(), max_chunk);
        auto* reply = response.mutable_fetch();
        reply->set_offset(f.offset());
        reply->set_data(it->second.substr(f.offset(), length));
        reply->set_eof(f.offset() + reply->data().size() >= it->second.size());
        break;
      }
      default:
        peer.send_error(request.id(), v1::Error::INTERNAL, "the fake does not do that");
        return true;
    }
    peer.send(response);
    return true;
  }
};

std::string test_bytes(std::size_t n, unsigned seed = 1) {
  std::string s(n, '\0');
  for (std::size_t i = 0; i < n; ++i) s[i] = static_cast<char>((i * 131 + seed * 7 + (i >> 8)) & 0xff);
  return s;
}

Options quick() {
  Options o;
  o.connect_timeout = std::chrono::milliseconds(5000);
  o.read_timeout = std::chrono::milliseconds(5000);
  o.write_timeout = std::chrono::milliseconds(5000);
  return o;
}

TEST(Client, HelloSendsTokenAndVersionAndKeepsLimits) {
  FakeBlobs blobs;
  FakeServer server([&](const v1::Request& r, const Peer& p) { return blobs.handle(r, p); });
  Client client(server.address(), quick());
  const v1::HelloReply reply = client.hello("sesame");
  EXPECT_EQ(blobs.token, "sesame");
  EXPECT_EQ(reply.server_version(), "fake 0");
  ASSERT_EQ(reply.job_types_size(), 1);
  EXPECT_EQ(client.limits().max_chunk_bytes(), 1000u);
  EXPECT_TRUE(client.is_open());
}

TEST(Client, UploadIsChunkedAtTheServersLimitAndStoredWhole) {
  FakeBlobs blobs;
  FakeServer server([&](const v1::Request& r, const Peer& p) { return blobs.handle(r, p); });
  Client client(server.address(), quick());
  client.hello("t");
  const std::string data = test_bytes(10500);
  std::vector<std::uint64_t> progress;
  const v1::Digest digest = client.upload_blob(data, [&](std::uint64_t done, std::uint64_t total) {
    EXPECT_EQ(total, data.size());
    progress.push_back(done);
  });
  EXPECT_EQ(digest.sha256(), proto::sha256_hex(data));
  EXPECT_EQ(digest.size(), data.size());
  ASSERT_EQ(blobs.stored.count(digest.sha256()), 1u);
  EXPECT_EQ(blobs.stored[digest.sha256()], data);
  ASSERT_EQ(blobs.puts.size(), 11u);  // ten of 1000 bytes, one of 500
  std::uint64_t expected_offset = 0;
  for (const auto& [offset, size] : blobs.puts) {
    EXPECT_EQ(offset, expected_offset);
    EXPECT_LE(size, 1000u);
    expected_offset += size;
  }
  EXPECT_EQ(progress.back(), data.size());

  // The server has it now: a second upload only asks.
  blobs.puts.clear();
  EXPECT_EQ(client.upload_blob(data).sha256(), digest.sha256());
  EXPECT_TRUE(blobs.puts.empty());
}

TEST(Client, UploadChunksFitTheServersFrameLimit) {
  FakeBlobs blobs;
  blobs.max_chunk = 1 << 20;
  blobs.max_frame = 3000;
  FakeServer server([&](const v1::Request& r, const Peer& p) { return blobs.handle(r, p); });
  Client client(server.address(), quick());
  client.hello("t");
  const std::string data = test_bytes(20000);
  client.upload_blob(data);
  EXPECT_EQ(blobs.stored.begin()->second, data);
  EXPECT_LE(server.largest_frame(), 3000u);
  EXPECT_GT(blobs.puts.size(), 1u);
}

TEST(Client, UploadOfTheEmptyBlob) {
  FakeBlobs blobs;
  FakeServer server([&](const v1::Request& r, const Peer& p) { return blobs.handle(r, p); });
  Client client(server.address(), quick());
  client.hello("t");
  const v1::Digest d = client.upload_blob("");
  EXPECT_EQ(d.sha256(), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(blobs.stored.count(d.sha256()), 1u);
}

TEST(Client, BrokenUploadResumesFromTheServersOffset) {
  FakeBlobs blobs;
  blobs.drop_after_puts = 4;  // the connection breaks after the server took 4000 bytes
  FakeServer server([&](const v1::Request& r, const Peer& p) { return blobs.handle(r, p); });
  const std::string data = test_bytes(10500, 3);
  {
    Client first(server.address(), quick());
    first.hello("t");
    EXPECT_THROW(first.upload_blob(data), ConnectionError);
    EXPECT_FALSE(first.is_open());
  }
  ASSERT_EQ(blobs.puts.size(), 4u);
  Client second(server.address(), quick());
  second.hello("t");
  std::uint64_t first_progress = ~std::uint64_t{0};
  second.upload_blob(data, [&](std::uint64_t done, std::uint64_t) {
    if (first_progress == ~std::uint64_t{0}) first_progress = done;
  });
  EXPECT_EQ(first_progress, 4000u);
  EXPECT_EQ(blobs.puts[4].first, 4000u);  // resumed where the server was, not from 0
  std::uint64_t sent = 0;
  for (const auto& put : blobs.puts) sent += put.second;
  EXPECT_EQ(sent, data.size());  // no byte sent twice
  EXPECT_EQ(blobs.stored[proto::sha256_hex(data)], data);
}

TEST(Client, UploadRequeriesWhenTheOffsetMovesUnderIt) {
  FakeBlobs blobs;
  const std::string data = test_bytes(5000, 5);
  int puts_seen = 0;
  FakeServer server([&](const v1::Request& r, const Peer& p) {
    if (r.has_blob_put() && ++puts_seen == 3) {
      // Another client's upload of the same blob lands first: the server now holds one more chunk.
      std::lock_guard lock(blobs.mutex);
      std::string& held = blobs.partial[r.blob_put().digest().sha256()];
      held += data.substr(held.size(), 1000);
    }
    return blobs.handle(r, p);
  });
  Client client(server.address(), quick());
  client.hello("t");
  client.upload_blob(data);
  EXPECT_EQ(blobs.stored[proto::sha256_hex(data)], data);
}

TEST(Client, FetchIsChunkedAndVerified) {
  FakeBlobs blobs;
  const std::string data = test_bytes(4321, 9);
  blobs.stored[proto::sha256_hex(data)] = data;
  FakeServer server([&](const v1::Request& r, const Peer& p) { return blobs.handle(r, p); });
  Client client(server.address(), quick());
  client.hello("t");
  EXPECT_EQ(client.fetch(digest_of(data)), data);

  // A digest the server has not got: its error, with the field.
  try {
    client.fetch(digest_of("something else"));
    FAIL() << "expected a ServerError";
  } catch (const ServerError& e) {
    EXPECT_EQ(e.code(), v1::Error::NOT_FOUND);
    EXPECT_EQ(e.field(), "digest");
  }
  EXPECT_THROW(client.fetch(v1::Digest()), std::invalid_argument);  // no digest at all is refused before sending
}

TEST(Client, FetchedBytesThatDoNotMatchTheDigestAreRefused) {
  FakeBlobs blobs;
  const std::string data = test_bytes(2500, 11);
  std::string corrupted = data;
  corrupted[1234] ^= 0x40;
  blobs.stored[proto::sha256_hex(data)] = corrupted;
  FakeServer server([&](const v1::Request& r, const Peer& p) { return blobs.handle(r, p); });
  Client client(server.address(), quick());
  client.hello("t");
  try {
    client.fetch(digest_of(data));
    FAIL() << "expected a ServerError";
  } catch (const ServerError& e) {
    EXPECT_EQ(e.code(), v1::Error::DATA_LOSS);
    EXPECT_EQ(e.field(), "digest.sha256");
  }
  // A blob shorter than its digest says is refused too.
  blobs.stored[proto::sha256_hex(data)] = data.substr(0, 2000);
  try {
    client.fetch(digest_of(data));
    FAIL() << "expected a ServerError";
  } catch (const ServerError& e) {
    EXPECT_EQ(e.code(), v1::Error::DATA_LOSS);
    EXPECT_EQ(e.field(), "digest.size");
  }
}

TEST(Client, FetchFromAServerThatNeverAdvancesFails) {
  FakeBlobs blobs;
  FakeServer server([&](const v1::Request& r, const Peer& p) {
    if (!r.has_fetch()) return blobs.handle(r, p);
    v1::Response response;
    response.set_id(r.id());
    response.mutable_fetch()->set_offset(r.fetch().offset());  // no data, no end
    p.send(response);
    return true;
  });
  Client client(server.address(), quick());
  client.hello("t");
  EXPECT_THROW(client.fetch(digest_of("abc")), ConnectionError);
}

TEST(Client, ServerErrorsCarryCodeMessageAndField) {
  FakeBlobs blobs;
  FakeServer server([&](const v1::Request& r, const Peer& p) {
    if (r.has_submit()) {
      p.send_error(r.id(), v1::Error::INVALID_ARGUMENT, "must be in (0, 1], got -0.2", "job.material.ggx.alpha");
      return true;
    }
    if (r.has_status()) {
      v1::Response response;
      response.set_id(r.id());
      response.mutable_status()->set_workers(2);
      p.send(response);
      return true;
    }
    return blobs.handle(r, p);
  });
  Client client(server.address(), quick());
  client.hello("t");
  v1::JobSpec job;
  job.mutable_material()->mutable_ggx()->set_alpha(-0.2);
  try {
    client.submit(job);
    FAIL() << "expected a ServerError";
  } catch (const ServerError& e) {
    EXPECT_EQ(e.code(), v1::Error::INVALID_ARGUMENT);
    EXPECT_EQ(e.field(), "job.material.ggx.alpha");
    EXPECT_EQ(e.message(), "must be in (0, 1], got -0.2");
    EXPECT_STREQ(e.what(), "job.material.ggx.alpha: must be in (0, 1], got -0.2 (INVALID_ARGUMENT)");
  }
  // An error answer leaves the connection usable.
  EXPECT_TRUE(client.is_open());
  EXPECT_EQ(client.status().workers(), 2u);
}

TEST(Client, JobRequestsCarryTheirFields) {
  FakeBlobs blobs;
  v1::Request last;
  FakeServer server([&](const v1::Request& r, const Peer& p) {
    if (r.has_hello()) return blobs.handle(r, p);
    last = r;
    v1::Response response;
    response.set_id(r.id());
    switch (r.body_case()) {
      case v1::Request::kSubmit:
        response.mutable_submit()->set_job_id("j-1");
        response.mutable_submit()->set_state(v1::JOB_STATE_QUEUED);
        break;
      case v1::Request::kCancel:
        response.mutable_cancel()->set_state(v1::JOB_STATE_CANCELLED);
        break;
      case v1::Request::kGetResult:
        response.mutable_result()->set_job_id(r.get_result().job_id());
        response.mutable_result()->set_state(v1::JOB_STATE_SUCCEEDED);
        response.mutable_result()->add_outputs()->set_name("albedo.exr");
        break;
      case v1::Request::kListJobs:
        response.mutable_jobs()->add_jobs()->set_job_id("j-1");
        break;
      default:
        return false;
    }
    p.send(response);
    return true;
  });
  Client client(server.address(), quick());
  client.hello("t");
  v1::JobSpec job;
  job.set_name("gold");
  job.mutable_material()->mutable_ggx()->set_alpha(0.3);
  const auto submitted = client.submit(job, 7, "ci-build-42");
  EXPECT_EQ(submitted.job_id(), "j-1");
  EXPECT_EQ(last.submit().priority(), 7);
  EXPECT_EQ(last.submit().idempotency_key(), "ci-build-42");
  EXPECT_EQ(last.submit().job().name(), "gold");
  EXPECT_DOUBLE_EQ(last.submit().job().material().ggx().alpha(), 0.3);

  EXPECT_EQ(client.cancel("j-1"), v1::JOB_STATE_CANCELLED);
  EXPECT_EQ(last.cancel().job_id(), "j-1");
  const auto result = client.result("j-1");
  ASSERT_EQ(result.outputs_size(), 1);
  EXPECT_EQ(result.outputs(0).name(), "albedo.exr");
  EXPECT_EQ(client.list_jobs(5, v1::JOB_STATE_RUNNING).jobs_size(), 1);
  EXPECT_EQ(last.list_jobs().limit(), 5u);
  EXPECT_EQ(last.list_jobs().state(), v1::JOB_STATE_RUNNING);
}

TEST(Client, WatchDeliversEveryEventUntilTheFinalOne) {
  FakeBlobs blobs;
  FakeServer server([&](const v1::Request& r, const Peer& p) {
    if (!r.has_watch()) return blobs.handle(r, p);
    v1::Response stale;  // a leftover of some earlier, abandoned request: skipped
    stale.set_id(r.id() + 1000);
    stale.mutable_event()->set_final(true);
    p.send(stale);
    for (int i = 1; i <= 4; ++i) {
      v1::Response response;
      response.set_id(r.id());
      auto* e = response.mutable_event();
      e->set_job_id(r.watch().job_id());
      e->set_sequence(i);
      e->set_fraction(i / 4.0);
      e->set_state(i < 4 ? v1::JOB_STATE_RUNNING : v1::JOB_STATE_SUCCEEDED);
      e->set_final(i == 4);
      p.send(response);
    }
    return true;
  });
  Client client(server.address(), quick());
  client.hello("t");
  std::vector<std::uint64_t> sequence;
  const v1::JobEvent last = client.watch("j-9", [&](const v1::JobEvent& e) {
    EXPECT_EQ(e.job_id(), "j-9");
    sequence.push_back(e.sequence());
  });
  EXPECT_EQ(sequence, (std::vector<std::uint64_t>{1, 2, 3, 4}));
  EXPECT_TRUE(last.final());
  EXPECT_EQ(last.state(), v1::JOB_STATE_SUCCEEDED);
}

TEST(Client, ASilentServerTimesOut) {
  FakeBlobs blobs;
  FakeServer server([&](const v1::Request& r, const Peer& p) {
    if (r.has_status()) return true;  // never answers
    return blobs.handle(r, p);
  });
  Options options = quick();
  options.read_timeout = std::chrono::milliseconds(200);
  Client client(server.address(), options);
  client.hello("t");
  EXPECT_THROW(client.status(), TimeoutError);
  EXPECT_FALSE(client.is_open());
  EXPECT_THROW(client.status(), ConnectionError);  // closed, and says so
}

TEST(Client, ConnectionLevelErrorClosesTheClient) {
  FakeBlobs blobs;
  FakeServer server([&](const v1::Request& r, const Peer& p) {
    if (!r.has_status()) return blobs.handle(r, p);
    p.send_error(0, v1::Error::UNAVAILABLE, "the server is shutting down");
    return false;
  });
  Client client(server.address(), quick());
  client.hello("t");
  try {
    client.status();
    FAIL() << "expected a ServerError";
  } catch (const ServerError& e) {
    EXPECT_EQ(e.code(), v1::Error::UNAVAILABLE);
  }
  EXPECT_FALSE(client.is_open());
}

TEST(Client, GarbledAnswersAreConnectionErrors) {
  // An oversized declared length, a frame that is not a Response, and an answer of the wrong kind.
  const std::vector<std::function<void(const v1::Request&, const Peer&)>> garbles = {
      [](const v1::Request&, const Peer& p) { p.send_raw(std::string("\x80\x80\x80\x80\x80\x20", 6)); },
      [](const v1::Request&, const Peer& p) { p.send_raw(std::string("\x03\xff\xff\xff", 4)); },
      [](const v1::Request& r, const Peer& p) {
        v1::Response wrong;
        wrong.set_id(r.id());
        wrong.mutable_hello();
        p.send(wrong);
      },
  };
  for (std::size_t i = 0; i < garbles.size(); ++i) {
    FakeBlobs blobs;
    FakeServer server([&](const v1::Request& r, const Peer& p) {
      if (!r.has_status()) return blobs.handle(r, p);
      garbles[i](r, p);
      return true;
    });
    Client client(server.address(), quick());
    client.hello("t");
    EXPECT_THROW(client.status(), ConnectionError) << "garble " << i;
    EXPECT_FALSE(client.is_open());
  }
}

TEST(Client, UnixSocket) {
  char dir_template[] = "/tmp/kiln-client-test-XXXXXX";
  ASSERT_NE(::mkdtemp(dir_template), nullptr);
  const std::string path = std::string(dir_template) + "/kilnd.sock";
  {
    FakeBlobs blobs;
    FakeServer server([&](const v1::Request& r, const Peer& p) { return blobs.handle(r, p); }, path);
    Client client("unix:" + path, quick());
    EXPECT_EQ(client.hello("").server_version(), "fake 0");
    const std::string data = test_bytes(3000);
    client.upload_blob(data);
    EXPECT_EQ(client.fetch(digest_of(data)), data);
  }
  std::filesystem::remove_all(dir_template);
}

TEST(Client, BadAddressesAreRefusedWithAReason) {
  const std::vector<std::string> addresses = {
      "",           "localhost", "localhost:", ":7700", "host:0",
      "host:65536", "host:77x",  "::1:7700",   "unix:", "unix:/" + std::string(200, 'x')};
  for (const std::string& address : addresses) {
    EXPECT_THROW(Client(address, quick()), std::invalid_argument) << address;
  }
}

TEST(Client, NobodyListeningIsAConnectionError) {
  // A port that was free a moment ago.
  int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  socklen_t len = sizeof a;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  ::close(fd);
  EXPECT_THROW(Client("127.0.0.1:" + std::to_string(ntohs(a.sin_port)), quick()), ConnectionError);
  EXPECT_THROW(Client("unix:/nonexistent/kilnd.sock", quick()), ConnectionError);
}

}  // namespace
}  // namespace kiln::client
