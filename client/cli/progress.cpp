#include "client/cli/progress.h"

#include <algorithm>
#include <cmath>
#include <ostream>

#include "client/cli/format.h"
#include "proto/kiln.pb.h"
#include "proto/text.h"

namespace kiln::cli {
namespace {

constexpr int kBarWidth = 24;
constexpr double kMinPlainInterval = 1.0;   // seconds between plain lines
constexpr int kPlainSteps = 10;             // plain lines per whole job: one each 10 %
constexpr double kPlainHeartbeat = 30.0;    // seconds after which a plain line comes anyway
constexpr double kMinRedrawInterval = 0.1;  // seconds between redraws of the terminal line

std::string percent(double fraction) {
  const double f = std::clamp(std::isfinite(fraction) ? fraction : 0.0, 0.0, 1.0);
  // Floor, so that 100 % only shows when the job is done.
  return std::to_string(static_cast<int>(std::floor(f * 100))) + "%";
}

// The 10 % mark a fraction has reached; the small slack keeps 0.6 from counting as 0.5999... .
int step_of(double fraction) {
  const double f = std::clamp(std::isfinite(fraction) ? fraction : 0.0, 0.0, 1.0);
  return static_cast<int>(std::floor(f * kPlainSteps + 1e-9));
}

}  // namespace

std::string state_name(int job_state) {
  switch (job_state) {
    case v1::JOB_STATE_QUEUED:
      return "queued";
    case v1::JOB_STATE_RUNNING:
      return "running";
    case v1::JOB_STATE_SUCCEEDED:
      return "succeeded";
    case v1::JOB_STATE_FAILED:
      return "failed";
    case v1::JOB_STATE_CANCELLED:
      return "cancelled";
    default:
      return "unknown";
  }
}

ProgressPrinter::ProgressPrinter(std::ostream& out, bool terminal, int columns)
    : out_(out), terminal_(terminal), columns_(std::max(columns, 20)) {}

ProgressPrinter::~ProgressPrinter() { finish(); }

std::string ProgressPrinter::describe(const v1::JobEvent& e) {
  std::string s = state_name(e.state());
  switch (e.state()) {
    case v1::JOB_STATE_RUNNING:
      s += " " + percent(e.fraction());
      if (e.eta_seconds() >= 0) s += "  ETA " + format_duration(e.eta_seconds());
      if (e.error_estimate() >= 0) s += "  error " + format_error(e.error_estimate());
      s += "  " + format_count(e.samples()) + " samples";
      break;
    case v1::JOB_STATE_SUCCEEDED:
      // A cache hit ends without running: no time or samples of its own to show.
      if (e.samples() == 0 && e.elapsed_seconds() <= 0) break;
      s += " after " + format_duration(e.elapsed_seconds()) + ", " + format_count(e.samples()) + " samples";
      if (e.error_estimate() >= 0) s += ", error " + format_error(e.error_estimate());
      break;
    default:
      break;
  }
  if (!e.message().empty())
    s += (e.state() == v1::JOB_STATE_FAILED ? ": " : "  (") + proto::printable(e.message()) +
         (e.state() == v1::JOB_STATE_FAILED ? "" : ")");
  return s;
}

void ProgressPrinter::draw(const std::string& line) {
  // Cut to the terminal's width: a wrapped line cannot be redrawn with \r.
  std::string shown = line.substr(0, static_cast<std::size_t>(columns_ - 1));
  out_ << "\r" << shown << "\x1b[K" << std::flush;
  drawn_ = true;
}

void ProgressPrinter::update(const v1::JobEvent& e, double now) {
  const bool state_changed = e.state() != last_state_;
  const bool final = e.final();
  if (terminal_) {
    if (!state_changed && !final && now - last_draw_ < kMinRedrawInterval) return;
    const double f = std::clamp(std::isfinite(e.fraction()) ? e.fraction() : 0.0, 0.0, 1.0);
    const int filled = e.state() == v1::JOB_STATE_SUCCEEDED ? kBarWidth : static_cast<int>(f * kBarWidth);
    std::string line;
    if (e.state() == v1::JOB_STATE_RUNNING || e.state() == v1::JOB_STATE_SUCCEEDED) {
      line = "[" + std::string(static_cast<std::size_t>(filled), '#') +
             std::string(static_cast<std::size_t>(kBarWidth - filled), '.') + "] ";
    }
    // No job id: the line above says which job, and the width is better spent on the figures.
    draw(line + describe(e));
    last_draw_ = now;
    if (final) finish();
  } else {
    const bool stepped = step_of(e.fraction()) > last_step_;
    const bool quiet_long = now - last_print_ >= kPlainHeartbeat;
    const bool message_changed = !e.message().empty() && e.message() != last_message_;
    const bool due = (stepped || quiet_long || message_changed) && now - last_print_ >= kMinPlainInterval;
    if (!(state_changed || final || due)) return;
    out_ << "job " << e.job_id() << ": " << describe(e) << "\n" << std::flush;
    last_print_ = now;
    // Steps count from the 10 % mark last reached, so lines fall near 10 %, 20 %, ... whatever the event timing.
    last_step_ = step_of(e.fraction());
    last_message_ = e.message();
  }
  last_state_ = e.state();
}

void ProgressPrinter::transfer(const std::string& name, std::uint64_t done, std::uint64_t total, double now) {
  if (!terminal_) return;
  if (done != total && now - last_draw_ < kMinRedrawInterval) return;
  const double f = total ? static_cast<double>(done) / static_cast<double>(total) : 1.0;
  const int filled = static_cast<int>(std::clamp(f, 0.0, 1.0) * kBarWidth);
  draw("fetching " + proto::printable(name) + " [" + std::string(static_cast<std::size_t>(filled), '#') +
       std::string(static_cast<std::size_t>(kBarWidth - filled), '.') + "] " + format_bytes(done) + " of " +
       format_bytes(total));
  last_draw_ = now;
}

void ProgressPrinter::finish() {
  if (terminal_ && drawn_) {
    out_ << "\n" << std::flush;
    drawn_ = false;
  }
}

}  // namespace kiln::cli
