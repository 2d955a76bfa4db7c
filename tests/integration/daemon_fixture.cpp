#include "tests/integration/daemon_fixture.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <thread>

namespace kiln::test {

Daemon::Daemon(std::vector<std::string> extra_flags, std::filesystem::path dir, std::vector<std::string> environment) {
  if (dir.empty()) {
    std::random_device rd;
    dir =
        std::filesystem::temp_directory_path() / ("kiln_it_" + std::to_string(::getpid()) + "_" + std::to_string(rd()));
  }
  dir_ = dir;
  std::filesystem::create_directories(dir_);
  socket_ = dir_ / "kilnd.sock";
  token_ = "integration-test-token-0123456789";
  const auto token_file = dir_ / "tokens";
  { std::ofstream(token_file) << token_ << "\n"; }
  std::filesystem::permissions(token_file, std::filesystem::perms::owner_read | std::filesystem::perms::owner_write);
  const auto out = dir_ / "kilnd.out";
  std::filesystem::remove(out);
  std::vector<std::string> args = {KILND_BIN,
                                   "--listen",
                                   "127.0.0.1:0",
                                   "--socket",
                                   socket_.string(),
                                   "--store",
                                   (dir_ / "store").string(),
                                   "--token-file",
                                   token_file.string()};
  args.insert(args.end(), extra_flags.begin(), extra_flags.end());
  pid_ = ::fork();
  if (pid_ == 0) {
    const std::string out_s = out.string(), err_s = (dir_ / "kilnd.log").string();
    if (!freopen(out_s.c_str(), "w", stdout) || !freopen(err_s.c_str(), "a", stderr)) _exit(127);
    for (std::string& e : environment) ::putenv(e.data());
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    ::execv(argv[0], argv.data());
    _exit(127);
  }
  // kilnd prints "kilnd: listening on 127.0.0.1:PORT" once it accepts connections.
  for (int i = 0; i < 600; ++i) {
    std::ifstream in(out);
    std::string line;
    while (std::getline(in, line)) {
      const std::string prefix = "kilnd: listening on 127.0.0.1:";
      if (line.rfind(prefix, 0) == 0) port_ = static_cast<unsigned>(std::stoul(line.substr(prefix.size())));
    }
    if (port_ != 0 && std::filesystem::exists(socket_)) return;
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) == pid_) {
      pid_ = -1;
      throw std::runtime_error("kilnd exited at start: " + log());
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  throw std::runtime_error("kilnd did not start within 30 s: " + log());
}

Daemon::~Daemon() {
  if (pid_ > 0) terminate();
  if (!keep_) {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
}

std::string Daemon::log() const {
  std::ifstream in(dir_ / "kilnd.log");
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void Daemon::kill9() {
  if (pid_ <= 0) return;
  ::kill(pid_, SIGKILL);
  int status = 0;
  ::waitpid(pid_, &status, 0);
  pid_ = -1;
}

bool Daemon::wait_for_crash(double seconds) {
  if (pid_ <= 0) return false;
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  for (;;) {
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) == pid_) {
      pid_ = -1;
      return WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL;
    }
    if (std::chrono::steady_clock::now() >= until) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

int Daemon::terminate() {
  if (pid_ <= 0) return -1;
  ::kill(pid_, SIGTERM);
  int status = 0;
  ::waitpid(pid_, &status, 0);
  pid_ = -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

long Daemon::rss_kib() const {
  std::ifstream in("/proc/" + std::to_string(pid_) + "/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
  }
  return -1;
}

int connect_tcp(unsigned port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

unsigned port_of(const std::string& tcp_address) {
  return static_cast<unsigned>(std::stoul(tcp_address.substr(tcp_address.rfind(':') + 1)));
}

}  // namespace kiln::test
