// TLS on kilnd's TCP listener, against the real daemon, with a CA and certificates the test makes itself
// (tests/tools/make_test_certs.sh, with the openssl command): what kilnd refuses at start.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <utility>

namespace kiln {
namespace {

// The test's own CA and certificates, made once per run (P-256 keys: a fraction of a second), removed at exit.
struct CertDir {
  std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("kiln_tls_certs_" + std::to_string(::getpid()));
  CertDir() {
    const std::string command =
        std::string(KILN_SOURCE_DIR) + "/tests/tools/make_test_certs.sh " + path.string() + " 2>&1";
    if (std::system(command.c_str()) != 0) {
      throw std::runtime_error("cannot make the test certificates with " + command + " (is openssl installed?)");
    }
  }
  ~CertDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};
const std::filesystem::path& cert_dir() {
  static const CertDir dir;
  return dir.path;
}
std::string cert(const char* name) { return (cert_dir() / name).string(); }

// kilnd with TLS, its certificate made for `server` (server or wrong-name), optionally requiring client

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// Runs `command` through the shell; its exit status and its output (stdout and stderr).
std::pair<int, std::string> run(const std::string& command) {
  FILE* p = ::popen((command + " 2>&1").c_str(), "r");
  if (!p) return {-1, "popen failed"};
  std::string out;
  char buf[4096];
  while (std::fgets(buf, sizeof buf, p)) out += buf;
  const int status = ::pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
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
  // kilnd with `flags`, stopped by SIGTERM after `seconds` if it is still running.
  std::pair<int, std::string> kilnd(const std::string& flags, int seconds = 20) const {
    return run("timeout -s TERM " + std::to_string(seconds) + " " + std::string(KILND_BIN) + " --store " +
               (dir / "store").string() + " --token-file " + (dir / "tokens").string() + " " + flags);
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
    const auto [status, out] = s.kilnd("--listen 0.0.0.0:0 --insecure-tcp", 2);
    EXPECT_TRUE(contains(out, "kilnd: listening on 0.0.0.0:")) << out;
    EXPECT_TRUE(contains(out, "tokens and jobs cross the network in clear")) << out;
  }
  {
    const auto [status, out] =
        s.kilnd("--listen 0.0.0.0:0 --tls-cert " + cert("server.pem") + " --tls-key " + cert("server.key"), 2);
    EXPECT_TRUE(contains(out, "kilnd: listening on 0.0.0.0:")) << out;
    EXPECT_TRUE(contains(out, "TLS 1.2+ on TCP")) << out;
  }
  {  // loopback stays as it was: no TLS needed
    const auto [status, out] = s.kilnd("--listen 127.0.0.1:0", 2);
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

}  // namespace
}  // namespace kiln
