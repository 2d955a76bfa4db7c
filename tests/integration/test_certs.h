// The TLS tests' own CA and certificates (tests/tools/make_test_certs.sh lists them), made once per process in a
// temporary folder that is removed at exit. Needs the openssl command and KILN_SOURCE_DIR.
#pragma once

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <string>

namespace kiln::test {

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

// The folder, made on first use (P-256 keys: a fraction of a second).
inline const std::filesystem::path& cert_dir() {
  static const CertDir dir;
  return dir.path;
}
// One of its files: "ca.pem", "server.key", ...
inline std::string cert(const std::string& name) { return (cert_dir() / name).string(); }

}  // namespace kiln::test
