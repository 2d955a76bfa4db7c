// TLS on kilnd's TCP listener, against the real daemon, with a CA and certificates the test makes itself
// (tests/tools/make_test_certs.sh, with the openssl command): a job's round trip, the refusals (a plain client, a
// certificate from another CA or for another host, a client certificate missing or from another CA), the handshake
// inside the hello deadline, the token never on the wire in clear, and the command line's --tls-ca.
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "client/lib/client.h"
#include "proto/kiln.pb.h"
#include "tests/integration/daemon_fixture.h"
#include "tests/integration/raw_connection.h"
#include "tests/integration/service_client.h"
#include "tests/integration/test_certs.h"
#include "tests/support/run_command.h"

namespace kiln {
namespace {

using client::Client;
using client::TlsError;
using test::cert;
using test::cert_dir;
using test::Daemon;
using test::ggx_job;
using Clock = std::chrono::steady_clock;

// kilnd with TLS, its certificate made for `server` (server or wrong-name), optionally requiring client
// certificates from the test's CA.
std::vector<std::string> tls_flags(const std::string& server = "server", bool client_ca = false) {
  std::vector<std::string> f = {"--tls-cert", cert_dir() / (server + ".pem"), "--tls-key",
                                cert_dir() / (server + ".key")};
  if (client_ca) f.insert(f.end(), {"--tls-client-ca", cert("ca.pem")});
  return f;
}

client::Options tls_options(const char* ca = "ca.pem", const char* client_name = nullptr) {
  client::Options o;
  o.connect_timeout = std::chrono::seconds(5);
  o.read_timeout = std::chrono::seconds(10);
  o.tls.ca_file = cert(ca);
  if (client_name) {
    o.tls.cert_file = cert(std::string(client_name) + ".pem");
    o.tls.key_file = cert(std::string(client_name) + ".key");
  }
  return o;
}

// What a connection attempt threw (the empty string if it did not), and how long it took.
template <class F>
std::pair<std::string, double> failure_of(F attempt) {
  const auto start = Clock::now();
  std::string what;
  try {
    attempt();
  } catch (const std::exception& e) {
    what = e.what();
  }
  return {what, std::chrono::duration<double>(Clock::now() - start).count()};
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// Waits up to 5 s for the daemon's log to hold `part` (it is written just after the event a test provokes).
bool log_has(const Daemon& d, const std::string& part) {
  for (int i = 0; i < 100; ++i) {
    if (contains(d.log(), part)) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return false;
}

TEST(Tls, AJobMakesTheRoundTripOverTls) {
  Daemon d(tls_flags());
  EXPECT_TRUE(log_has(d, "TLS 1.2+ on TCP")) << d.log();
  Client c(d.tcp(), tls_options());
  c.hello(d.token());
  const std::string id = c.submit(ggx_job(0.4, 256, 8)).job_id();
  EXPECT_EQ(c.watch(id).state(), v1::JOB_STATE_SUCCEEDED);
  const v1::JobResult result = c.result(id);
  ASSERT_GT(result.outputs_size(), 0);
  for (const auto& out : result.outputs()) {
    EXPECT_EQ(c.fetch(out.digest()).size(), out.digest().size()) << out.name();  // fetch verifies the SHA-256
  }
  // The host name works as well as the address: the certificate names both.
  Client by_name("localhost:" + std::to_string(test::port_of(d.tcp())), tls_options());
  EXPECT_NO_THROW(by_name.hello(d.token()));
  // The Unix socket stays plain.
  EXPECT_NO_THROW(test::connect(d, true).status());
}

// A hello deadline far beyond any wait of a loaded machine: an answer well before it came at once, not from it.
constexpr double kLongHelloDeadline = 600;

std::vector<std::string> with_long_hello_deadline(std::vector<std::string> flags) {
  flags.push_back("--hello-deadline");
  flags.push_back(std::to_string(static_cast<int>(kLongHelloDeadline)));
  return flags;
}

// A client without TLS gets a kiln error saying what to do, at once, instead of a TLS alert it cannot read.
TEST(Tls, APlainClientOfATlsServerIsToldToUseTls) {
  Daemon d(with_long_hello_deadline(tls_flags()));
  const auto [what, seconds] = failure_of([&] { test::connect(d); });
  EXPECT_TRUE(contains(what, "accepts only TLS on TCP")) << what;
  EXPECT_TRUE(contains(what, "--tls-ca")) << what;
  EXPECT_TRUE(contains(what, "FAILED_PRECONDITION")) << what;
  EXPECT_LT(seconds, kLongHelloDeadline / 2);  // no waiting for the deadline
  EXPECT_TRUE(log_has(d, "the client spoke plain TCP to the TLS listener")) << d.log();
}

// The reverse: a TLS client of a kilnd without TLS is told the server does not speak it, at once.
TEST(Tls, ATlsClientOfAPlainServerIsToldItDoesNotSpeakTls) {
  Daemon d(with_long_hello_deadline({}));
  std::string type;
  const auto [what, seconds] = failure_of([&] {
    try {
      Client c(d.tcp(), tls_options());
    } catch (const TlsError&) {
      type = "TlsError";
      throw;
    }
  });
  EXPECT_EQ(type, "TlsError") << what;
  EXPECT_TRUE(contains(what, "does not speak TLS")) << what;
  EXPECT_LT(seconds, kLongHelloDeadline / 2);  // no waiting for the deadline
  EXPECT_TRUE(log_has(d, "the client began a TLS handshake, but this kilnd serves TCP without TLS")) << d.log();
}

// A server certificate the client's CA did not sign is refused; the server logs the failed handshake with the peer
// and its reason, and the connections already open carry on.
TEST(Tls, AServerCertificateFromAnotherCaIsRefused) {
  Daemon d(tls_flags());
  Client good(d.tcp(), tls_options());
  good.hello(d.token());
  const auto [what, seconds] = failure_of([&] { Client c(d.tcp(), tls_options("other-ca.pem")); });
  EXPECT_TRUE(contains(what, "the server's certificate is refused")) << what;
  EXPECT_TRUE(contains(what, "other-ca.pem")) << what;
  EXPECT_TRUE(log_has(d, "(127.0.0.1:")) << d.log();
  EXPECT_TRUE(log_has(d, "TLS handshake failed: ")) << d.log();
  EXPECT_NO_THROW(good.status());
}

// The certificate must name the host the client connected to, although the CA is trusted.
TEST(Tls, AServerCertificateForAnotherHostIsRefused) {
  Daemon d(tls_flags("wrong-name"));
  const auto [what, seconds] = failure_of([&] { Client c(d.tcp(), tls_options()); });
  EXPECT_TRUE(contains(what, "does not name the host 127.0.0.1")) << what;
}

TEST(Tls, AClientCertificateIsRequiredWhenTheServerHasAClientCa) {
  Daemon d(tls_flags("server", true));
  EXPECT_TRUE(log_has(d, "client certificates required")) << d.log();
  // Under TLS 1.3 the server's refusal arrives after the client's side of the handshake: at hello at the latest.
  const auto [without, s1] = failure_of([&] {
    Client c(d.tcp(), tls_options());
    c.hello(d.token());
  });
  EXPECT_TRUE(contains(without, "the server refused the TLS connection")) << without;
  EXPECT_TRUE(contains(without, "client certificate")) << without;
  EXPECT_TRUE(log_has(d, "TLS handshake failed: peer did not return a certificate")) << d.log();

  const auto [foreign, s2] = failure_of([&] {
    Client c(d.tcp(), tls_options("ca.pem", "other-client"));
    c.hello(d.token());
  });
  EXPECT_TRUE(contains(foreign, "does not accept the client certificate")) << foreign;
  EXPECT_TRUE(log_has(d, "client certificate: unable to get local issuer certificate")) << d.log();

  Client c(d.tcp(), tls_options("ca.pem", "client"));
  c.hello(d.token());
  EXPECT_NO_THROW(c.status());
}

// The handshake counts inside the hello deadline: a socket that says nothing, or starts a handshake and stalls, is
// closed when the deadline passes, as before TLS. Tolerance: the deadline is 1 s, the check allows 4 s for a loaded
// machine.
TEST(Tls, AHandshakeMustEndWithinTheHelloDeadline) {
  Daemon d([] {
    auto f = tls_flags();
    f.insert(f.end(), {"--hello-deadline", "1"});
    return f;
  }());
  const unsigned port = test::port_of(d.tcp());
  test::RawConnection silent(port);
  test::RawConnection stalled(port);
  ASSERT_TRUE(stalled.send_bytes(std::string("\x16\x03\x01\x02\x00", 5)));  // a ClientHello's record header only
  const auto start = Clock::now();
  EXPECT_TRUE(silent.closed_by_server(std::chrono::seconds(4)));
  EXPECT_TRUE(stalled.closed_by_server(std::chrono::seconds(4)));
  EXPECT_GE(std::chrono::duration<double>(Clock::now() - start).count(), 0.5);
  EXPECT_TRUE(log_has(d, "no TLS handshake and hello within the hello deadline (1 s")) << d.log();
  Client c(d.tcp(), tls_options());
  EXPECT_NO_THROW(c.hello(d.token()));
}

// Relays one connection between a client and kilnd and keeps every byte that passes, both ways: what someone on
// the network would see.
class TapProxy {
 public:
  explicit TapProxy(unsigned upstream_port) : upstream_port_(upstream_port) {
    listener_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof addr;
    if (::bind(listener_, reinterpret_cast<sockaddr*>(&addr), len) != 0 || ::listen(listener_, 1) != 0 ||
        ::getsockname(listener_, reinterpret_cast<sockaddr*>(&addr), &len) != 0) {
      throw std::runtime_error("proxy: cannot listen");
    }
    port_ = ntohs(addr.sin_port);
    thread_ = std::thread([this] { relay(); });
  }
  ~TapProxy() {
    ::shutdown(listener_, SHUT_RDWR);
    thread_.join();
    ::close(listener_);
  }
  std::string address() const { return "127.0.0.1:" + std::to_string(port_); }
  // Everything relayed, once the client has closed its connection (waits up to 10 s).
  std::string captured() {
    for (int i = 0; i < 200 && !done_; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
    std::lock_guard lock(mutex_);
    return bytes_;
  }

 private:
  void relay() {
    const int client = ::accept(listener_, nullptr, nullptr);
    if (client < 0) return;
    const int server = test::connect_tcp(upstream_port_);
    pollfd fds[2] = {{client, POLLIN, 0}, {server, POLLIN, 0}};
    char buf[65536];
    for (bool open = server >= 0; open;) {
      if (::poll(fds, 2, 10'000) <= 0) break;
      for (int i = 0; i < 2 && open; ++i) {
        if (!(fds[i].revents & (POLLIN | POLLHUP | POLLERR))) continue;
        const ssize_t n = ::recv(fds[i].fd, buf, sizeof buf, 0);
        if (n <= 0) {
          open = false;
          break;
        }
        {
          std::lock_guard lock(mutex_);
          bytes_.append(buf, static_cast<std::size_t>(n));
        }
        if (::send(fds[1 - i].fd, buf, static_cast<std::size_t>(n), MSG_NOSIGNAL) != n) open = false;
      }
    }
    ::close(client);
    if (server >= 0) ::close(server);
    done_ = true;
  }

  unsigned upstream_port_;
  int listener_ = -1;
  unsigned port_ = 0;
  std::thread thread_;
  std::mutex mutex_;
  std::string bytes_;
  std::atomic<bool> done_{false};
};

// Says hello and submits a job through the proxy, and returns what crossed it.
std::string captured_session(const Daemon& d, const client::Options& options) {
  TapProxy proxy(test::port_of(d.tcp()));
  {
    Client c(proxy.address(), options);
    c.hello(d.token());
    const std::string id = c.submit(ggx_job(0.25, 256, 8)).job_id();
    c.watch(id);
  }
  return proxy.captured();
}

TEST(Tls, TheTokenNeverCrossesTheNetworkInClear) {
  // The control: without TLS the tap sees the token and the job's name, so the check below can see what it looks for.
  {
    Daemon plain;
    const std::string bytes = captured_session(plain, {});
    EXPECT_TRUE(contains(bytes, plain.token())) << bytes.size() << " bytes";
    EXPECT_TRUE(contains(bytes, "ggx 0.25")) << bytes.size() << " bytes";
  }
  Daemon d(tls_flags());
  const std::string bytes = captured_session(d, tls_options());
  EXPECT_GT(bytes.size(), 1000u);  // the handshake and the session did pass
  EXPECT_FALSE(contains(bytes, d.token()));
  EXPECT_FALSE(contains(bytes, d.token().substr(0, 12)));  // nor a recognisable part of it
  EXPECT_FALSE(contains(bytes, "ggx 0.25"));
}

// Runs `command` through the shell; its exit status and its output (stdout and stderr).
std::pair<int, std::string> run(const std::string& command) {
  const test::CommandResult r = test::run_command(command + " 2>&1");
  return {r.status, r.output};
}

// A folder with a token file (mode 0600), for kilnd runs that start and stop (or refuse to start) at once.
struct Scratch {
  std::filesystem::path dir = std::filesystem::temp_directory_path() / ("kiln_tls_start_" + std::to_string(::getpid()));
  Scratch() {
    std::filesystem::create_directories(dir);
    const auto tokens = dir / "tokens";
    { std::ofstream(tokens) << "tls-startup-test-token-0123456789\n"; }
    std::filesystem::permissions(tokens, std::filesystem::perms::owner_read | std::filesystem::perms::owner_write);
  }
  ~Scratch() {
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
  }
  std::string command(const std::string& flags) const {
    return std::string(KILND_BIN) + " --store " + (dir / "store").string() + " --token-file " +
           (dir / "tokens").string() + " " + flags;
  }
  // kilnd with `flags`, which must refuse to start: stopped by SIGTERM after 120 s if it runs after all.
  std::pair<int, std::string> kilnd(const std::string& flags) const {
    return run("timeout -s TERM 120 " + command(flags));
  }
  // kilnd with `flags`, stopped by SIGTERM once it says it listens (or ends by itself; or after 120 s at most): its
  // output, whatever the machine's load. The log is emptied before kilnd starts: the background job's own
  // redirection may come after the first grep, which would then find the previous call's "listening on".
  std::string kilnd_until_listening(const std::string& flags) const {
    const std::string log = (dir / "kilnd.out").string();
    return run("(: > " + log + "; " + command(flags) + " > " + log +
               " 2>&1 & pid=$!; for i in $(seq 1200); do grep -q 'listening on' " +
               log + " && break; kill -0 $pid 2>/dev/null || break; sleep 0.1; done; kill -TERM $pid 2>/dev/null; " +
               "wait $pid; cat " + log + ")")
        .second;
  }
};

// Tokens must not cross a network in clear: a non-loopback address needs TLS, or --insecure-tcp said out loud.
TEST(TlsStartup, ANonLoopbackListenNeedsTlsOrInsecureTcp) {
  const Scratch s;
  {
    const auto [status, out] = s.kilnd("--listen 0.0.0.0:0");
    EXPECT_EQ(status, 1) << out;
    EXPECT_TRUE(contains(out, "0.0.0.0 is not a loopback address")) << out;
    EXPECT_TRUE(contains(out, "--tls-cert FILE and --tls-key FILE")) << out;
    EXPECT_TRUE(contains(out, "--insecure-tcp")) << out;
  }
  {
    const std::string out = s.kilnd_until_listening("--listen 0.0.0.0:0 --insecure-tcp");
    EXPECT_TRUE(contains(out, "kilnd: listening on 0.0.0.0:")) << out;
    EXPECT_TRUE(contains(out, "tokens and jobs cross the network in clear")) << out;
  }
  {
    const std::string out = s.kilnd_until_listening("--listen 0.0.0.0:0 --tls-cert " + cert("server.pem") +
                                                    " --tls-key " + cert("server.key"));
    EXPECT_TRUE(contains(out, "kilnd: listening on 0.0.0.0:")) << out;
    EXPECT_TRUE(contains(out, "TLS 1.2+ on TCP")) << out;
  }
  {  // loopback stays as it was: no TLS needed
    const std::string out = s.kilnd_until_listening("--listen 127.0.0.1:0");
    EXPECT_TRUE(contains(out, "kilnd: listening on 127.0.0.1:")) << out;
  }
}

// Each unusable TLS file is named with what is wrong and what to do, before kilnd listens.
TEST(TlsStartup, UnusableTlsFilesAreNamed) {
  const Scratch s;
  const std::string missing = (s.dir / "missing.pem").string();
  {
    const auto [status, out] =
        s.kilnd("--listen 127.0.0.1:0 --tls-cert " + missing + " --tls-key " + cert("server.key"));
    EXPECT_EQ(status, 1) << out;
    EXPECT_TRUE(contains(out, "--tls-cert " + missing + ": cannot read it (No such file or directory)")) << out;
  }
  {
    const auto [status, out] =
        s.kilnd("--listen 127.0.0.1:0 --tls-cert " + cert("server.pem") + " --tls-key " + cert("client.key"));
    EXPECT_EQ(status, 1) << out;
    EXPECT_TRUE(contains(out, "does not belong to the certificate in --tls-cert")) << out;
  }
  {  // a certificate given as the key (private, so that only its content is wrong)
    const auto not_a_key = s.dir / "certificate.key";
    std::filesystem::copy_file(cert("server.pem"), not_a_key);
    std::filesystem::permissions(not_a_key, std::filesystem::perms::owner_read);
    const auto [status, out] =
        s.kilnd("--listen 127.0.0.1:0 --tls-cert " + cert("server.pem") + " --tls-key " + not_a_key.string());
    EXPECT_EQ(status, 1) << out;
    EXPECT_TRUE(contains(out, "not a PEM private key")) << out;
  }
  {
    const auto open_key = s.dir / "open.key";
    std::filesystem::copy_file(cert("server.key"), open_key);
    std::filesystem::permissions(open_key, std::filesystem::perms::others_read, std::filesystem::perm_options::add);
    const auto [status, out] =
        s.kilnd("--listen 127.0.0.1:0 --tls-cert " + cert("server.pem") + " --tls-key " + open_key.string());
    EXPECT_EQ(status, 1) << out;
    EXPECT_TRUE(contains(out, "others can read it")) << out;
    EXPECT_TRUE(contains(out, "chmod o-rwx")) << out;
  }
  {
    const auto [status, out] = s.kilnd("--listen 127.0.0.1:0 --tls-cert " + cert("server.pem") + " --tls-key " +
                                       cert("server.key") + " --tls-client-ca " + missing);
    EXPECT_EQ(status, 1) << out;
    EXPECT_TRUE(contains(out, "--tls-client-ca " + missing + ": cannot read it")) << out;
  }
}

#ifdef KILN_BIN

TEST(Tls, TheCommandLineConnectsWithTlsCa) {
  Daemon d(tls_flags("server", true));
  const std::string kiln = "KILN_TOKEN=" + d.token() + " " + std::string(KILN_BIN) + " --server " + d.tcp();
  const std::string client_cert = " --tls-cert " + cert("client.pem") + " --tls-key " + cert("client.key");
  {
    const auto [status, out] = run(kiln + " --tls-ca " + cert("ca.pem") + client_cert + " status");
    EXPECT_EQ(status, 0) << out;
    EXPECT_TRUE(contains(out, "kilnd 0.1.0")) << out;
  }
  {  // the same from the environment
    const auto [status, out] = run("KILN_TLS_CA=" + cert("ca.pem") + " KILN_TLS_CERT=" + cert("client.pem") +
                                   " KILN_TLS_KEY=" + cert("client.key") + " " + kiln + " status");
    EXPECT_EQ(status, 0) << out;
  }
  {
    const auto [status, out] = run(kiln + " status");
    EXPECT_EQ(status, 3) << out;
    EXPECT_TRUE(contains(out, "accepts only TLS")) << out;
  }
  {
    const auto [status, out] = run(kiln + " --tls-ca " + cert("ca.pem") + " status");
    EXPECT_EQ(status, 3) << out;
    EXPECT_TRUE(contains(out, "client certificate")) << out;
  }
  {
    const auto [status, out] = run(kiln + " --tls-ca " + (cert_dir() / "missing.pem").string() + " status");
    EXPECT_EQ(status, 2) << out;
    EXPECT_TRUE(contains(out, "missing.pem: cannot read it")) << out;
    EXPECT_TRUE(contains(out, "--tls-ca")) << out;
  }
}
#endif

}  // namespace
}  // namespace kiln
