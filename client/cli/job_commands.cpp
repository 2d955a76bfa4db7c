// The commands about one job: `kiln submit`, `watch`, `result`, `fetch` and `cancel`.
#include <ostream>

#include "client/cli/follow.h"
#include "client/cli/format.h"
#include "client/cli/job_file.h"
#include "client/cli/outputs.h"
#include "client/cli/progress.h"
#include "client/cli/report.h"
#include "client/cli/subcommands.h"
#include "client/cli/submission.h"
#include "proto/text.h"

namespace kiln::cli {
namespace {

namespace fs = std::filesystem;

// The one job id on the command line of `command` ("kiln watch").
std::string job_id_argument(const Flags& f, const std::string& command) {
  if (f.positional.empty()) throw UsageError("missing job id: `" + command + " ID` (list jobs with `kiln jobs`)");
  if (f.positional.size() > 1) {
    throw UsageError("unexpected argument '" + f.positional[1] + "': `" + command + "` takes one job id");
  }
  const std::string& id = f.positional[0];
  // Ids are at most 64 bytes (kiln.proto); refusing here names the mistake better than the server could.
  if (id.empty() || id.size() > 64) throw UsageError("job id '" + id + "': expected 1 to 64 characters");
  return id;
}

// "job ID STATE: MESSAGE", for a job that did not succeed.
std::string job_state_line(const std::string& id, const v1::JobResult& r) {
  return "job " + id + " " + state_name(r.state()) + (r.error().message().empty() ? "" : ": " + proto::printable(r.error().message()));
}

void print_failed_result(std::ostream& out, const v1::JobResult& r) {
  out << "job " << r.job_id() << " " << state_name(r.state())
      << (r.name().empty() ? "" : ": " + proto::printable(r.name())) << "\n";
  if (r.has_error()) {
    out << "  error: " << (r.error().field().empty() ? "" : proto::printable(r.error().field()) + ": ")
        << proto::printable(r.error().message()) << " ("
        << v1::Error::Code_Name(r.error().code()) << ")\n";
  }
}

void print_succeeded_result(std::ostream& out, const v1::JobResult& r) {
  out << "job " << r.job_id() << " succeeded" << (r.name().empty() ? "" : ": " + proto::printable(r.name())) << "\n";
  out << "  cost: " << cost_line(r, r.report().cache_hit()) << "\n";
  out << "  outputs (write them into a folder with `kiln fetch " << r.job_id() << " --out DIR`):\n";
  for (const auto& o : r.outputs()) {
    out << "    " << o.name() << "  " << format_bytes(o.digest().size())
        << (o.description().empty() ? "" : "  " + o.description()) << "\n      "
        << (o.media_type().empty() ? "-" : o.media_type()) << ", colour space "
        << (o.color_space().empty() ? "-" : o.color_space()) << ", sha256 " << o.digest().sha256() << "\n";
  }
  const auto& b = r.report();
  if (!b.baker_version().empty()) out << "  baker: " << b.baker_version() << "\n";
  if (b.plan_size()) out << "  plan:\n";
  for (const auto& d : b.plan()) {
    out << "    " << d.effect() << ": " << (d.enabled() ? "on" : "off") << (d.forced() ? " (forced)" : "")
        << (d.reason().empty() ? "" : ", " + d.reason()) << "\n";
  }
}

}  // namespace

int cmd_submit(Context& ctx, const Flags& f) {
  if (f.positional.empty()) {
    throw UsageError("missing job file: `kiln submit JOB.textproto` (examples: client/examples/)");
  }
  if (f.positional.size() > 1) {
    throw UsageError("unexpected argument '" + f.positional[1] + "': submit one job file at a time");
  }
  const std::string path = f.positional[0];
  const std::int32_t priority = priority_of(f);
  const std::string key = idempotency_key_of(f);
  v1::JobSpec spec;
  std::string text;
  read_job_file(path, spec, text);
  const std::optional<fs::path> dir = out_dir_of(f);
  const std::string label = path == "-" ? "<stdin>" : path;

  const v1::SubmitReply reply = submit_job(ctx, spec, priority, key, [&](const std::string& field) {
    auto at = locate_field(text, field);
    return at ? label + ":" + *at : label;
  });
  const std::string& id = reply.job_id();
  if (!f.has("--wait") && !dir) {
    ctx.out << id << "\n" << std::flush;
    ctx.err << "kiln: submitted job " << id << " (" << state_name(reply.state())
            << (reply.cache_hit() ? ", a cache hit: already done" : "") << "); follow it with `kiln watch " << id
            << "`\n";
    return kExitOk;
  }
  ctx.err << "kiln: submitted job " << id << (reply.cache_hit() ? " (a cache hit: already done)" : "") << "\n";
  const v1::JobEvent final = follow_job(ctx, id, false);
  return save_and_summarize(ctx, final, id, dir, reply.cache_hit());
}

int cmd_watch(Context& ctx, const Flags& f) {
  const std::string id = job_id_argument(f, "kiln watch");
  connected_client(ctx);
  return save_and_summarize(ctx, follow_job(ctx, id, false), id, std::nullopt, false);
}

int cmd_result(Context& ctx, const Flags& f) {
  const std::string id = job_id_argument(f, "kiln result");
  const v1::JobResult r = request_result(ctx, id, "");
  if (f.has("--json")) {
    ctx.out << result_json(r) << std::flush;
  } else {
    if (r.state() == v1::JOB_STATE_SUCCEEDED) {
      print_succeeded_result(ctx.out, r);
    } else {
      print_failed_result(ctx.out, r);
    }
    ctx.out << "  submitted " << format_time(r.submitted_unix()) << ", finished " << format_time(r.finished_unix())
            << "\n";
  }
  if (r.state() == v1::JOB_STATE_SUCCEEDED) return kExitOk;
  throw Failure(kExitJobFailed, job_state_line(id, r));
}

int cmd_fetch(Context& ctx, const Flags& f) {
  const std::string id = job_id_argument(f, "kiln fetch");
  const auto out = f.get("--out");
  if (!out) throw UsageError("--out: missing; fetch writes the outputs into a folder: add --out DIR");
  const fs::path dir = create_out_dir(*out);
  const v1::JobResult r = request_result(ctx, id, ", or `kiln submit --out` next time");
  if (r.state() != v1::JOB_STATE_SUCCEEDED) {
    throw Failure(kExitJobFailed, job_state_line(id, r) + "; it has no outputs to fetch");
  }
  const auto saved = save_outputs(ctx, r, dir);
  print_summary(ctx, r, false, dir, saved);
  return kExitOk;
}

int cmd_cancel(Context& ctx, const Flags& f) {
  const std::string id = job_id_argument(f, "kiln cancel");
  const v1::JobState state = request_cancel(ctx, id);
  if (state == v1::JOB_STATE_CANCELLED) {
    ctx.out << "job " << id << " cancelled\n";
    return kExitOk;
  }
  throw Failure(kExitJobFailed, "job " + id + " had already " + state_name(state) + "; it was not cancelled");
}

}  // namespace kiln::cli
