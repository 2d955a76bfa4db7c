// The commands about the server: `kiln status` and `kiln jobs`.
#include <algorithm>
#include <iomanip>
#include <ostream>

#include "client/cli/format.h"
#include "client/cli/progress.h"
#include "client/cli/subcommands.h"
#include "proto/bounds.h"
#include "proto/text.h"

namespace kiln::cli {
namespace {

using client::ConnectionError;
using client::ServerError;

void print_status(Context& ctx, const v1::ServerStatus& s) {
  const v1::HelloReply& h = ctx.hello;
  const v1::Limits& l = h.limits();
  std::ostream& out = ctx.out;
  out << "kilnd at " << ctx.server << ": " << (s.server_version().empty() ? h.server_version() : s.server_version())
      << ", protocol " << h.protocol_version() << ", up " << format_duration(s.uptime_seconds()) << "\n";
  out << "  jobs: " << s.queued() << " queued, " << s.running() << " running, " << s.jobs_completed() << " completed, "
      << s.jobs_failed() << " failed, " << s.cache_hits() << " cache hits\n";
  out << "  workers: " << s.workers() << ", threads: " << s.threads() << ", connections: " << s.connections() << "\n";
  out << "  store: " << format_bytes(s.store_bytes())
      << (s.store_limit_bytes() ? " of " + format_bytes(s.store_limit_bytes()) : std::string(" (no limit)")) << "\n";
  std::string types;
  for (const auto& t : h.job_types()) types += (types.empty() ? "" : ", ") + t;
  out << "  job types: " << (types.empty() ? "-" : types) << "\n";
  out << "  limits: frame " << format_bytes(l.max_frame_bytes()) << ", chunk " << format_bytes(l.max_chunk_bytes())
      << ", blob " << format_bytes(l.max_blob_bytes()) << ", queue " << l.max_queued_jobs() << " jobs, heartbeat "
      << l.heartbeat_seconds() << " s\n"
      << std::flush;
}

// --state STATE; JOB_STATE_UNSPECIFIED (every state) without.
v1::JobState state_filter_of(const Flags& f) {
  const auto v = f.get("--state");
  if (!v) return v1::JOB_STATE_UNSPECIFIED;
  for (int s = v1::JOB_STATE_QUEUED; s <= v1::JOB_STATE_CANCELLED; ++s) {
    if (*v == state_name(s)) return static_cast<v1::JobState>(s);
  }
  throw UsageError("--state: expected one of queued, running, succeeded, failed, cancelled, got '" + *v + "'");
}

void print_jobs_table(std::ostream& out, const v1::JobList& list) {
  std::size_t id_width = 2;
  for (const auto& j : list.jobs()) id_width = std::max(id_width, j.job_id().size());
  out << std::left << std::setw(static_cast<int>(id_width)) << "ID"
      << "  " << std::setw(10) << "STATE" << std::setw(13) << "TYPE" << std::right << std::setw(4) << "PRI"
      << "  " << std::left << std::setw(20) << "SUBMITTED" << std::right << std::setw(12) << "BAKING"
      << "  " << std::left << std::setw(6) << "CACHE"
      << "NAME\n";
  for (const auto& j : list.jobs()) {
    out << std::left << std::setw(static_cast<int>(id_width)) << j.job_id() << "  " << std::setw(10)
        << state_name(j.state()) << std::setw(13) << (j.type().empty() ? "-" : j.type()) << std::right << std::setw(4)
        << j.priority() << "  " << std::left << std::setw(20) << format_time(j.submitted_unix()) << std::right
        << std::setw(12) << format_duration(j.seconds()) << "  " << std::left << std::setw(6)
        << (j.cache_hit() ? "hit" : "-") << proto::printable(j.name()) << "\n";
  }
  out << std::flush;
}

}  // namespace

int cmd_status(Context& ctx, const Flags&) {
  v1::ServerStatus s;
  try {
    s = connected_client(ctx).status();
  } catch (const ServerError& e) {
    throw Failure(kExitServer, "kilnd at " + ctx.server + " could not tell its status: " + describe_server_error(e));
  } catch (const ConnectionError& e) {
    throw_connection_lost(ctx, e, "asking for its status");
  }
  print_status(ctx, s);
  return kExitOk;
}

int cmd_jobs(Context& ctx, const Flags& f) {
  if (!f.positional.empty()) throw UsageError("unexpected argument '" + f.positional[0] + "' (see `kiln jobs --help`)");
  std::uint32_t limit = 0;
  if (auto v = f.get("--limit")) limit = static_cast<std::uint32_t>(parse_whole("--limit", *v, bounds::WholeRange{1, bounds::kListJobsLimit.hi}));
  const v1::JobState state = state_filter_of(f);
  v1::JobList list;
  try {
    list = connected_client(ctx).list_jobs(limit, state);
  } catch (const ServerError& e) {
    throw Failure(e.code() == v1::Error::INVALID_ARGUMENT ? kExitUsage : kExitServer,
                  "kilnd at " + ctx.server + " could not list its jobs: " + describe_server_error(e));
  } catch (const ConnectionError& e) {
    throw_connection_lost(ctx, e, "listing jobs");
  }
  if (list.jobs().empty()) {
    ctx.err << "kiln: kilnd at " << ctx.server << " has no jobs" << (f.has("--state") ? " in that state" : "") << "\n";
    return kExitOk;
  }
  print_jobs_table(ctx.out, list);
  return kExitOk;
}

}  // namespace kiln::cli
