// Starts the real kilnd in a temporary folder (TCP on a free loopback port, and a Unix socket), and stops it.
#pragma once

#include <sys/types.h>

#include <filesystem>
#include <string>
#include <vector>

namespace kiln::test {

class Daemon {
 public:
  // Starts kilnd with a fresh store under a new temporary folder (or `store_dir` to reuse one), extra flags
  // appended, and `environment` ("NAME=value") added to its environment. Waits until it prints where it listens.
  // Throws std::runtime_error if it does not start.
  explicit Daemon(std::vector<std::string> extra_flags = {}, std::filesystem::path dir = {},
                  std::vector<std::string> environment = {});
  ~Daemon();  // SIGTERM, wait; the folder is removed unless keep() was called

  std::string tcp() const { return "127.0.0.1:" + std::to_string(port_); }
  std::string unix_address() const { return "unix:" + socket_.string(); }
  const std::string& token() const { return token_; }
  const std::filesystem::path& dir() const { return dir_; }
  pid_t pid() const { return pid_; }
  std::string log() const;  // what kilnd wrote to stderr so far

  void kill9();     // SIGKILL, as a crash
  // Waits up to `seconds` for kilnd to exit by itself (a crash point, crash_point.h); true if it did, by SIGKILL.
  bool wait_for_crash(double seconds);
  int terminate();  // SIGTERM and wait; the exit status
  void keep() { keep_ = true; }

  // The daemon's resident memory in KiB (from /proc).
  long rss_kib() const;

 private:
  std::filesystem::path dir_, socket_;
  std::string token_;
  unsigned port_ = 0;
  pid_t pid_ = -1;
  bool keep_ = false;
};

// Connects a plain socket to 127.0.0.1:port, for sending malformed bytes.
int connect_tcp(unsigned port);
unsigned port_of(const std::string& tcp_address);

}  // namespace kiln::test
