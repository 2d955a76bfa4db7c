// Runs a shell command for the tests that drive the real programs (kiln, kilnd, kiln-brdf).
#pragma once

#include <string>

namespace kiln::test {

struct CommandResult {
  int status = -1;     // the exit status; −1 when the command could not start or did not exit normally
  std::string output;  // what it wrote to stdout (add " 2>&1" to the command for stderr too)
};

// `command` through /bin/sh, as given; waits for it to exit.
CommandResult run_command(const std::string& command);

}  // namespace kiln::test
