#include "client/cli/build_runner.h"

#include <algorithm>
#include <deque>
#include <map>
#include <ostream>

#include "client/cli/build_checks.h"
#include "client/cli/follow.h"
#include "client/cli/format.h"
#include "client/cli/progress.h"
#include "client/cli/submission.h"
#include "proto/text.h"

namespace kiln::cli {
namespace {

namespace fs = std::filesystem;
using client::ConnectionError;
using client::ServerError;
using Status = BakeOutcome::Status;

// The connection is gone: the build cannot go on (every watch went with it).
struct ConnectionLost {
  std::string why;
};

bool connection_open(const Context& ctx) { return ctx.client && ctx.client->is_open(); }

class Runner {
 public:
  Runner(Context& ctx, const BuildPlan& plan, const BuildOptions& options)
      : ctx_(ctx), plan_(plan), options_(options), outcome_{std::vector<BakeOutcome>(plan.bakes.size()), 0, false} {}

  BuildOutcome run() {
    const double start = steady_seconds();
    try {
      connected_client(ctx_);
      upload_missing_blobs();
      submit_and_follow();
    } catch (const ConnectionLost& lost) {
      give_up(lost.why);
    }
    for (BakeOutcome& o : outcome_.bakes) {
      if (o.status == Status::skipped && o.failure.empty()) {
        o.failure_type = "skipped";
        o.failure = "not submitted: an earlier bake failed (`kiln build --keep-going` bakes the rest all the same)";
      }
    }
    outcome_.seconds = steady_seconds() - start;
    return std::move(outcome_);
  }

 private:
  // Asks the server for every input's digest at once, and uploads only the blobs it lacks.
  void upload_missing_blobs() {
    if (plan_.blobs.empty()) return;
    client::Client& c = connected_client(ctx_);
    const std::size_t batch = std::max<std::size_t>(1, c.limits().max_query_digests());
    std::vector<v1::Digest> all;
    for (const auto& [sha, bytes] : plan_.blobs) all.push_back(client::digest_of(bytes));
    std::vector<const std::string*> missing;
    std::uint64_t missing_bytes = 0;
    guard_connection("asking kilnd which inputs it holds", [&] {
      for (std::size_t i = 0; i < all.size(); i += batch) {
        const std::vector<v1::Digest> part(all.begin() + static_cast<std::ptrdiff_t>(i),
                                           all.begin() + static_cast<std::ptrdiff_t>(std::min(all.size(), i + batch)));
        const v1::BlobQueryReply reply = c.query_blobs(part);
        for (const auto& m : reply.missing()) {
          missing.push_back(&plan_.blobs.at(m.digest().sha256()));
          missing_bytes += m.digest().size();
        }
      }
    });
    ctx_.err << "kiln: " << all.size() << " inputs, " << missing.size() << " to upload (" << format_bytes(missing_bytes)
             << ")\n";
    ProgressPrinter printer(ctx_.err, ctx_.terminal.progress_in_place, ctx_.terminal.columns);
    std::uint64_t sent = 0;
    guard_connection("uploading the build's inputs", [&] {
      for (const std::string* bytes : missing) {
        c.upload_blob(*bytes, [&](std::uint64_t done, std::uint64_t) {
          printer.transfer("upload", sent + done, missing_bytes, steady_seconds());
        });
        sent += bytes->size();
      }
    });
    printer.finish();
  }

  void submit_and_follow() {
    std::size_t window = options_.jobs ? options_.jobs : plan_.bakes.size();
    // Cache hits aside, more than the queue holds would be refused.
    const std::uint32_t queue = connected_client(ctx_).limits().max_queued_jobs();
    if (queue) window = std::min<std::size_t>(window, queue);
    std::size_t next = 0;
    for (;;) {
      while (!stopped_ && next < plan_.bakes.size() && active_.size() < window) submit(next++);
      // Jobs that had ended at submit (cache hits) are finished once the window is submitted, so that with the
      // default window a failed check does not keep the rest from being submitted.
      if (!ended_.empty()) {
        const Ended e = ended_.front();
        ended_.pop_front();
        finish(e.bake, e.state, e.cache_hit);
        continue;
      }
      if (active_.empty()) break;
      client::Client::WatchEvent e;
      guard_connection("following the build's jobs", [&] { e = ctx_.client->next_watch_event(); });
      const auto it = active_.find(e.job_id);
      if (it == active_.end()) continue;
      const std::size_t i = it->second;
      if (e.error) {
        active_.erase(it);
        fail(i, Status::error, "job", "kilnd could not follow job " + e.job_id + ": " + e.error->message());
        continue;
      }
      if (!e.event.final()) continue;
      active_.erase(it);
      finish(i, e.event.state(), false);
    }
  }

  void submit(std::size_t i) {
    const PlannedBake& bake = plan_.bakes[i];
    BakeOutcome& o = outcome_.bakes[i];
    started_[i] = steady_seconds();
    v1::SubmitReply reply;
    try {
      reply = submit_job(ctx_, bake.spec, bake.priority, "", bake.where);
    } catch (const Failure& e) {
      if (!connection_open(ctx_)) throw ConnectionLost{e.what()};
      fail(i, Status::failed, "submit", e.what());
      return;
    }
    o.job_id = reply.job_id();
    const bool ended = reply.state() == v1::JOB_STATE_SUCCEEDED || reply.state() == v1::JOB_STATE_FAILED ||
                       reply.state() == v1::JOB_STATE_CANCELLED;
    if (ended) {
      ended_.push_back({i, reply.state(), reply.cache_hit()});
      return;
    }
    guard_connection("following job " + reply.job_id(), [&] { ctx_.client->start_watch(reply.job_id()); });
    active_.emplace(reply.job_id(), i);
  }

  // Bake i's job has ended in `state`: its result, its checks, its folder.
  void finish(std::size_t i, v1::JobState state, bool cache_hit) {
    const PlannedBake& bake = plan_.bakes[i];
    BakeOutcome& o = outcome_.bakes[i];
    v1::JobResult r;
    try {
      r = request_result(ctx_, o.job_id);
    } catch (const Failure& e) {
      if (!connection_open(ctx_)) throw ConnectionLost{e.what()};
      fail(i, Status::error, "job", e.what());
      return;
    }
    o.bake_seconds = r.report().seconds();
    o.error_estimate = r.has_report() ? r.report().error_estimate() : -1;
    o.samples = r.report().samples();
    if (state != v1::JOB_STATE_SUCCEEDED) {
      const auto& err = r.error();
      const bool named = err.field().empty() || err.message().rfind(err.field() + ":", 0) == 0;
      std::string why = proto::printable((named ? "" : err.field() + ": ") + err.message());
      if (!err.field().empty() && bake.where) {
        const std::string at = bake.where(err.field());
        if (!at.empty()) why = at + ": " + why;
      }
      fail(i, Status::failed, "job", "job " + o.job_id + " " + state_name(state) + (why.empty() ? "" : ": " + why));
      return;
    }
    const std::vector<CheckFailure> missed = run_checks(bake.checks, r);
    if (!missed.empty()) {
      std::string message;
      for (const CheckFailure& f : missed) message += (message.empty() ? "" : "; ") + f.message;
      fail(i, Status::failed, missed.front().check,
           message + " (" + bake.origin + "; the outputs in " + bake.output.string() + " were left as they were)");
      return;
    }
    try {
      o.files = write_output_folder(ctx_, r, bake.output);
    } catch (const Failure& e) {
      if (!connection_open(ctx_)) throw ConnectionLost{e.what()};
      fail(i, Status::error, "outputs", e.what());
      return;
    } catch (const ConnectionError& e) {
      throw ConnectionLost{"lost the connection to kilnd at " + ctx_.server + " while fetching the outputs of job " +
                           o.job_id + ": " + e.what()};
    }
    o.status = cache_hit || r.report().cache_hit() ? Status::cached : Status::baked;
    o.wall_seconds = steady_seconds() - started_[i];
    print_done(i);
  }

  void fail(std::size_t i, Status status, const std::string& type, const std::string& message) {
    BakeOutcome& o = outcome_.bakes[i];
    o.status = status;
    o.failure_type = type;
    o.failure = message;
    o.wall_seconds = started_.count(i) ? steady_seconds() - started_[i] : 0;
    if (!options_.keep_going) stopped_ = true;
    print_done(i);
  }

  // One line on stderr per bake as it ends.
  void print_done(std::size_t i) {
    const BakeOutcome& o = outcome_.bakes[i];
    const PlannedBake& bake = plan_.bakes[i];
    ++done_;
    ctx_.err << "kiln: [" << done_ << "/" << plan_.bakes.size() << "] " << bake.name << ": ";
    if (o.status == Status::baked || o.status == Status::cached) {
      ctx_.err << (o.status == Status::cached ? "cached" : "baked") << " (" << format_duration(o.bake_seconds)
               << " of baking, error " << format_error(o.error_estimate) << "), "
               << (o.files.written ? std::to_string(o.files.written) + " files written" : "no file changed") << " in "
               << bake.output.string() << "\n";
    } else {
      ctx_.err << "FAILED: " << o.failure << "\n";
    }
    ctx_.err << std::flush;
  }

  template <typename Fn>
  void guard_connection(const std::string& what, Fn fn) {
    try {
      fn();
    } catch (const ConnectionError& e) {
      throw ConnectionLost{"lost the connection to kilnd at " + ctx_.server + " while " + what + ": " + e.what()};
    } catch (const ServerError& e) {
      throw ConnectionLost{"kilnd at " + ctx_.server + " refused " + what + ": " + describe_server_error(e)};
    }
  }

  // Every bake not yet ended is an error of the build, not of the bake.
  void give_up(const std::string& why) {
    outcome_.connection_lost = true;
    ctx_.err << "kiln: " << why << "\n";
    for (std::size_t i = 0; i < outcome_.bakes.size(); ++i) {
      BakeOutcome& o = outcome_.bakes[i];
      if (o.status != Status::skipped || !o.failure.empty()) continue;
      o.status = Status::error;
      o.failure_type = "connection";
      o.failure = why + "; run the build again: the bakes that finished are cache hits";
    }
  }

  Context& ctx_;
  const BuildPlan& plan_;
  const BuildOptions options_;
  BuildOutcome outcome_;
  std::map<std::string, std::size_t> active_;  // job id -> bake, for the jobs being followed
  struct Ended {
    std::size_t bake;
    v1::JobState state;
    bool cache_hit;
  };
  std::deque<Ended> ended_;  // submitted, already ended, not yet finished
  std::map<std::size_t, double> started_;
  std::size_t done_ = 0;
  bool stopped_ = false;
};

}  // namespace

BuildOutcome run_build(Context& ctx, const BuildPlan& plan, const BuildOptions& options) {
  return Runner(ctx, plan, options).run();
}

}  // namespace kiln::cli
