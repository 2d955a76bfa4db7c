// The real `kiln` command line run against a test's kilnd (with a token file beside the daemon's store), and the
// bytes of a file it wrote: what the integration tests of the bake commands share.
#pragma once

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "tests/integration/daemon_fixture.h"
#include "tests/support/run_command.h"

namespace kiln::test {

inline std::string read(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

#ifdef KILN_BIN
struct CliRun {
  int status = -1;
  std::string said;  // stdout and stderr
};

inline CliRun kiln(const Daemon& d, const std::string& args) {
  const std::filesystem::path token = d.dir() / "cli-token";
  if (!std::filesystem::exists(token)) std::ofstream(token) << d.token() << "\n";
  const std::string command =
      std::string(KILN_BIN) + " --server " + d.tcp() + " --token-file " + token.string() + " " + args + " 2>&1";
  const CommandResult r = run_command(command);
  return {r.status, r.output};
}
#endif

}  // namespace kiln::test
