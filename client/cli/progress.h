// Progress of a job as `kiln` shows it: on a terminal one line redrawn in place (a bar, the fraction, ETA, error
// estimate, samples); otherwise plain lines for logs, few enough for CI output.
#pragma once

#include <cstdint>
#include <iosfwd>
#include <string>

namespace kiln::v1 {
class JobEvent;
}

namespace kiln::cli {

// "queued", "running", "succeeded", "failed", "cancelled" for a kiln.v1.JobState; "unknown" otherwise.
std::string state_name(int job_state);

class ProgressPrinter {
 public:
  // `terminal`: redraw one line with \r (the stream is a terminal `columns` wide); otherwise print plain lines.
  ProgressPrinter(std::ostream& out, bool terminal, int columns = 80);
  ~ProgressPrinter();

  // One event of a watch; `now` in seconds on any steady clock. Plain lines come on a change of state, on each
  // 10 % of progress, or after 30 s without one (so that a long bake still shows it is alive in a CI log), and
  // never more than one a second (a change of state always shows).
  void update(const v1::JobEvent& event, double now);
  // A transfer of `name`: `done` of `total` bytes. Terminal only; plain output says nothing until it is over.
  void transfer(const std::string& name, std::uint64_t done, std::uint64_t total, double now);
  // Ends a line being redrawn, so that what follows starts on its own line.
  void finish();

  // The text of one progress line for an event (without the job id or line ends), for the terminal and the log.
  static std::string describe(const v1::JobEvent& event);

 private:
  void draw(const std::string& line);

  std::ostream& out_;
  bool terminal_;
  int columns_;
  bool drawn_ = false;  // a line is on screen waiting to be redrawn
  int last_state_ = -1;
  int last_step_ = -1;  // the 10 % mark of the last plain line
  double last_print_ = -1e300, last_draw_ = -1e300;
  std::string last_message_;
};

}  // namespace kiln::cli
