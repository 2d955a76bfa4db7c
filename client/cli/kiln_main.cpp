// kiln: the command line of the kiln baking service (see `kiln --help` and client/cli/commands.cpp).
#include <sys/ioctl.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <iostream>
#include <string>
#include <vector>

#include "client/cli/commands.h"

int main(int argc, char** argv) {
  kiln::cli::Terminal terminal;
  // Progress goes to stderr, so stderr decides; TERM=dumb cannot move the cursor back.
  const char* term = std::getenv("TERM");
  terminal.progress_in_place = ::isatty(STDERR_FILENO) && !(term && std::strcmp(term, "dumb") == 0);
  winsize size{};
  if (terminal.progress_in_place && ::ioctl(STDERR_FILENO, TIOCGWINSZ, &size) == 0 && size.ws_col > 0) {
    terminal.columns = size.ws_col;
  }
  const std::vector<std::string> args(argv + 1, argv + argc);
  return kiln::cli::run_kiln(args, std::cout, std::cerr, terminal);
}
