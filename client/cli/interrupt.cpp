#include "client/cli/interrupt.h"

#include <unistd.h>

#include <csignal>

namespace kiln::cli {
namespace {

volatile std::sig_atomic_t g_interrupted = 0;

extern "C" void on_interrupt(int) {
  if (g_interrupted) {
    // Second Ctrl-C: leave at once, the job stays on the server.
    std::signal(SIGINT, SIG_DFL);
    std::raise(SIGINT);
    return;
  }
  g_interrupted = 1;
  static const char kMessage[] =
      "\nkiln: cancelling the job when the server next reports progress (Ctrl-C again quits and leaves it running)\n";
  [[maybe_unused]] const auto ignored = ::write(STDERR_FILENO, kMessage, sizeof kMessage - 1);
}

}  // namespace

void cancel_job_on_ctrl_c() { std::signal(SIGINT, on_interrupt); }

void quit_on_ctrl_c() { std::signal(SIGINT, SIG_DFL); }

bool ctrl_c_pressed() { return g_interrupted != 0; }

}  // namespace kiln::cli
