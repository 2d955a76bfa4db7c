#include "client/cli/follow.h"

#include <algorithm>
#include <chrono>
#include <ostream>
#include <thread>
#include <vector>

#include "client/cli/interrupt.h"
#include "client/cli/outputs.h"
#include "client/cli/progress.h"
#include "proto/text.h"

namespace kiln::cli {
namespace {

using client::ConnectionError;
using client::ServerError;

// Reconnections while following a job (a restarting daemon re-queues its jobs); waits 1, 2, 4, 8, 16, 16 s.
constexpr int kMaxWatchReconnects = 6;

// Why a job that did not succeed ended so, for its Failure.
std::string job_end_message(Context& ctx, const v1::JobEvent& final, const std::string& id) {
  std::string why = final.message();
  if (why.empty() && final.state() == v1::JOB_STATE_FAILED) {
    try {
      const v1::JobResult r = connected_client(ctx).result(id);
      why = r.error().message();
      if (!r.error().field().empty() && why.rfind(r.error().field() + ":", 0) != 0) {
        why = r.error().field() + ": " + why;
      }
    } catch (const std::exception&) {
      // The event already says it failed; the reason is a courtesy.
    }
  }
  return "job " + id + " " + state_name(final.state()) + (why.empty() ? "" : ": " + proto::printable(why));
}

// After the `reconnects`th broken watch: says why on stderr and waits before the next, or gives up.
void wait_before_rewatch(Context& ctx, const std::string& id, const std::string& why, int reconnects) {
  if (reconnects > kMaxWatchReconnects) {
    throw Failure(kExitServer, "gave up watching job " + id + " on kilnd at " + ctx.server + " (" + why +
                                   "); the job stays on the server: `kiln watch " + id + "` follows it again");
  }
  const int wait = std::min(1 << (reconnects - 1), 16);
  ctx.err << "kiln: " << why << " (kilnd at " << ctx.server << ", watching job " << id << "); trying again in " << wait
          << " s\n"
          << std::flush;
  std::this_thread::sleep_for(std::chrono::seconds(wait));
}

}  // namespace

v1::JobEvent follow_job(Context& ctx, const std::string& id, bool cancel_on_ctrl_c) {
  ProgressPrinter printer(ctx.err, ctx.terminal.progress_in_place, ctx.terminal.columns);
  int reconnects = 0;
  for (;;) {
    std::string why;
    try {
      if (!ctx.client || !ctx.client->is_open()) connect_and_greet(ctx);
      return ctx.client->watch(id, [&](const v1::JobEvent& e) {
        reconnects = 0;
        printer.update(e, steady_seconds());
        if (cancel_on_ctrl_c && ctrl_c_pressed() && !e.final()) throw Interrupted{};
      });
    } catch (const ServerError& e) {
      printer.finish();
      // UNAVAILABLE: the daemon is shutting down; it re-queues the job and a restarted one serves the watch.
      if (e.code() != v1::Error::UNAVAILABLE) throw_job_request_error(ctx, e, id, "watch job");
      why = "kilnd is unavailable: " + e.message();
    } catch (const ConnectionError& e) {
      printer.finish();
      why = "lost the connection: " + std::string(e.what());
    }
    ctx.client.reset();
    wait_before_rewatch(ctx, id, why, ++reconnects);
  }
}

v1::JobResult request_result(Context& ctx, const std::string& id, const std::optional<std::string>& unfinished_hint) {
  try {
    return connected_client(ctx).result(id);
  } catch (const ServerError& e) {
    if (unfinished_hint && e.code() == v1::Error::FAILED_PRECONDITION) {
      throw Failure(kExitJobFailed, "job " + id + " has not finished (" + e.message() + "); `kiln watch " + id +
                                        "` waits for it" + *unfinished_hint);
    }
    throw_job_request_error(ctx, e, id, "give the result of job");
  } catch (const ConnectionError& e) {
    throw_connection_lost(ctx, e, "asking for the result of job " + id);
  }
}

v1::JobState request_cancel(Context& ctx, const std::string& id) {
  try {
    return connected_client(ctx).cancel(id);
  } catch (const ServerError& e) {
    throw_job_request_error(ctx, e, id, "cancel job");
  } catch (const ConnectionError& e) {
    throw_connection_lost(ctx, e, "cancelling job " + id);
  }
}

int save_and_summarize(Context& ctx, const v1::JobEvent& final, const std::string& id,
                       const std::optional<std::filesystem::path>& dir, bool cache_hit) {
  if (final.state() != v1::JOB_STATE_SUCCEEDED) throw Failure(kExitJobFailed, job_end_message(ctx, final, id));
  const v1::JobResult r = request_result(ctx, id);
  std::vector<SavedFile> saved;
  if (dir) saved = save_outputs(ctx, r, *dir);
  print_summary(ctx, r, cache_hit, dir, saved);
  return kExitOk;
}

}  // namespace kiln::cli
