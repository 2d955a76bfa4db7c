// A real redis-server for the farm's tests: started on a Unix socket in a temporary directory (no TCP port, so tests
// running at once never collide), waited for until it answers PING, and stopped (or killed) by the test.
#pragma once

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "daemon/cluster/redis_client.h"

namespace kiln::test {

class RedisServer {
 public:
  // Debian's redis-server; tests skip, saying so, where it is missing.
  static std::string binary() {
    for (const char* p : {"/usr/bin/redis-server", "/usr/local/bin/redis-server"}) {
      if (::access(p, X_OK) == 0) return p;
    }
    return {};
  }
  static constexpr const char* kSkipMessage =
      "redis-server is not installed (Debian: apt-get install redis-server; deploy/setup.sh installs it)";

  // `extra` are more `--name value` arguments (e.g. {"--requirepass", "secret"}); `config_file`, if given, is read
  // first and the test's own settings (socket, directory) override it.
  explicit RedisServer(std::vector<std::string> extra = {}, std::string config_file = {})
      : extra_(std::move(extra)), config_file_(std::move(config_file)) {
    ::signal(SIGPIPE, SIG_IGN);  // as kilnd does: a write to a server that went away is an error, not a signal
    std::string pattern = (std::filesystem::temp_directory_path() / "kiln-redis-XXXXXX").string();
    if (::mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp failed for " + pattern);
    dir_ = pattern;
    start();
  }
  ~RedisServer() {
    kill();
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  RedisServer(const RedisServer&) = delete;
  RedisServer& operator=(const RedisServer&) = delete;

  std::string socket() const { return (dir_ / "redis.sock").string(); }
  std::string url() const { return "unix:" + socket(); }
  const std::filesystem::path& dir() const { return dir_; }
  cluster::RedisOptions options() const {
    cluster::RedisOptions o;
    o.address = cluster::parse_redis_url(url());
    return o;
  }

  // Starts the server (again, after stop() or kill(), on the same socket and directory, so its AOF is read back),
  // and returns once it answers PING.
  void start() {
    std::vector<std::string> args{binary()};
    if (!config_file_.empty()) args.push_back(config_file_);
    const std::vector<std::string> own{
        "--port", "0", "--unixsocket", socket(), "--unixsocketperm", "700", "--dir",     dir_.string(),
        "--save", "",  "--appendonly", "yes",    "--daemonize",      "no",  "--logfile", (dir_ / "redis.log").string()};
    args.insert(args.end(), own.begin(), own.end());
    args.insert(args.end(), extra_.begin(), extra_.end());
    pid_ = ::fork();
    if (pid_ < 0) throw std::runtime_error("fork failed");
    if (pid_ == 0) {
      std::vector<char*> argv;
      for (std::string& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      ::execv(argv[0], argv.data());
      ::_exit(127);
    }
    wait_until_ready();
  }
  // SIGTERM: Redis flushes its AOF and exits.
  void stop() { end(SIGTERM); }
  // SIGKILL: what a crash or a power cut leaves.
  void kill() { end(SIGKILL); }

 private:
  void end(int sig) {
    if (pid_ <= 0) return;
    ::kill(pid_, sig);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
  }
  // Polls PING until it answers. The bound only stops a broken server from hanging the test; it asserts nothing.
  void wait_until_ready() {
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    std::string last;
    while (std::chrono::steady_clock::now() < give_up) {
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        throw std::runtime_error("redis-server exited at start; see " + (dir_ / "redis.log").string());
      }
      try {
        cluster::RedisClient probe(options());
        probe.command({"PING"});
        return;
      } catch (const cluster::RedisError& e) {
        // NOAUTH: it is up, and wants the password the test gave it.
        if (e.code() == cluster::RedisErrc::refused) return;
        last = e.what();
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    throw std::runtime_error("redis-server did not answer within 60 s: " + last);
  }
  std::vector<std::string> extra_;
  std::string config_file_;
  std::filesystem::path dir_;
  pid_t pid_ = -1;
};

}  // namespace kiln::test
