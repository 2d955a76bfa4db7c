#include "daemon/auth.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>

namespace kiln::daemon {
namespace {

constexpr std::size_t kMinTokenLength = 16;

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return {};
  const auto e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

// Constant-time equality for equal lengths; different lengths compare unequal after the same amount of work on
// the stored token, so the attempt's length is all that timing could reveal.
bool equal_constant_time(std::string_view stored, std::string_view attempt) {
  unsigned char diff = stored.size() == attempt.size() ? 0 : 1;
  for (std::size_t i = 0; i < stored.size(); ++i) {
    const unsigned char a = i < attempt.size() ? static_cast<unsigned char>(attempt[i]) : 0;
    diff |= static_cast<unsigned char>(static_cast<unsigned char>(stored[i]) ^ a);
  }
  return diff == 0;
}

}  // namespace

void check_owner_only(const std::string& path, const std::string& what, const std::string& how_to_create) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    throw std::runtime_error(what + " " + path + ": cannot read it (" + std::strerror(errno) + "); " + how_to_create);
  }
  if (!S_ISREG(st.st_mode)) throw std::runtime_error(what + " " + path + ": is not a regular file");
  if ((st.st_mode & 077) != 0) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
    throw std::runtime_error(what + " " + path + ": others can access it (mode " + mode +
                             "); refusing to use it. Run: chmod 600 " + path);
  }
}

TokenSet TokenSet::load(const std::string& path) {
  check_owner_only(path, "token file", "create it with one token per line and mode 0600");
  std::ifstream in(path);
  if (!in) throw std::runtime_error("token file " + path + ": cannot open it (" + std::strerror(errno) + ")");
  std::vector<std::string> tokens;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    const std::string t = trim(line);
    if (t.empty() || t[0] == '#') continue;
    if (t.size() < kMinTokenLength) {
      throw std::runtime_error("token file " + path + ", line " + std::to_string(number) + ": token is " +
                               std::to_string(t.size()) + " characters, at least " + std::to_string(kMinTokenLength) +
                               " are required");
    }
    tokens.push_back(t);
  }
  if (tokens.empty()) throw std::runtime_error("token file " + path + ": holds no token");
  return from_tokens(std::move(tokens));
}

TokenSet TokenSet::from_tokens(std::vector<std::string> tokens) {
  TokenSet set;
  set.tokens_ = std::move(tokens);
  return set;
}

bool TokenSet::accepts(std::string_view token) const {
  bool ok = false;
  for (const std::string& t : tokens_) ok |= equal_constant_time(t, token);  // no early exit
  return ok && !token.empty();
}

std::string generate_token() {
  std::random_device rd;  // reads the OS's entropy source on Linux
  std::ostringstream out;
  for (int i = 0; i < 8; ++i) {
    char buf[9];
    std::snprintf(buf, sizeof buf, "%08x", static_cast<unsigned>(rd()));
    out << buf;
  }
  return out.str();
}

void write_token_file(const std::string& path, const std::string& token) {
  const std::string tmp = path + ".tmp";
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) throw std::runtime_error("token file " + tmp + ": cannot create it (" + std::strerror(errno) + ")");
  const std::string line = token + "\n";
  const bool ok = ::write(fd, line.data(), line.size()) == static_cast<ssize_t>(line.size()) && ::fsync(fd) == 0;
  ::close(fd);
  if (!ok || ::rename(tmp.c_str(), path.c_str()) != 0) {
    ::unlink(tmp.c_str());
    throw std::runtime_error("token file " + path + ": cannot write it (" + std::strerror(errno) + ")");
  }
}

}  // namespace kiln::daemon
