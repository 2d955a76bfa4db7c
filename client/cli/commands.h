// The `kiln` commands: parse the words after `kiln`, talk to kilnd, print, and return the exit status.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

namespace kiln::cli {

struct Terminal {
  bool progress_in_place = false;  // stderr is a terminal: redraw progress on one line
  int columns = 80;
};

// Runs `kiln ARGS...` (args without the program name) and returns the exit status (args.h: kExit*). Every error
// is reported on `err` as one line starting with "kiln: "; nothing is thrown. Reads KILN_SERVER, KILN_TOKEN,
// KILN_TOKEN_FILE, KILN_TLS_CA, KILN_TLS_CERT and KILN_TLS_KEY from the environment.
int run_kiln(const std::vector<std::string>& args, std::ostream& out, std::ostream& err, const Terminal& terminal);

}  // namespace kiln::cli
