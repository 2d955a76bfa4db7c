#include "client/cli/commands.h"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <optional>
#include <ostream>
#include <sstream>
#include <thread>

#include "client/cli/args.h"
#include "client/cli/bake_flags.h"
#include "client/cli/env_flags.h"
#include "client/cli/lightmap_flags.h"
#include "client/import/scene_import.h"
#include "client/cli/format.h"
#include "client/cli/job_file.h"
#include "client/cli/progress.h"
#include "client/cli/report.h"
#include "client/lib/client.h"

namespace kiln::cli {
namespace {

namespace fs = std::filesystem;
using client::Client;
using client::ConnectionError;
using client::ServerError;

constexpr const char* kVersion = "kiln 0.1.0 (protocol kiln.v1)";
constexpr const char* kDefaultServer = "127.0.0.1:7878";
// Reconnections while following a job (a restarting daemon re-queues its jobs); waits 1, 2, 4, 8, 16, 16 s.
constexpr int kMaxWatchReconnects = 6;
// Retries of one output's fetch after a broken connection.
constexpr int kMaxFetchRetries = 3;
constexpr std::size_t kMaxIdempotencyKeyBytes = 128;

constexpr const char* kHelp = R"(usage: kiln [--server ADDR] [--token-file FILE] COMMAND [ARGS]

kiln talks to kilnd, the kiln baking daemon: it submits bake jobs, follows them and fetches what they made.

commands:
  submit JOB.textproto [--wait] [--out DIR] [--priority N] [--idempotency-key KEY]
                        submit a job file (a kiln.v1.JobSpec in protobuf text format; see client/examples/)
  bake material --model MODEL [parameters] --out DIR
                        bake one material described by flags, wait, write its outputs and report.json into DIR
  bake env IMAGE | --constant R,G,B | --faces PX NX PY NY PZ NZ [options] [--out DIR]
                        upload an HDR environment and bake it for image-based lighting (specular cube chain,
                        irradiance, SH, DFG table); with --out, wait and write the outputs into DIR
  bake lightmap SCENE [--env IMAGE | --env-constant R,G,B] [--resolution N] [--target-error E] [options] --out DIR
                        import a glTF, OBJ or FBX scene, upload it and bake its lightmaps (irradiance, validity,
                        error, preview; optionally radiance, AO, SH); with --out, wait and write them into DIR
  watch ID              follow a job until it ends, showing its progress
  result ID [--json]    a finished job's outcome: cost, planner decisions, outputs with their digests
  fetch ID --out DIR    write a finished job's outputs and report.json into DIR
  cancel ID             cancel a queued or running job
  status                the server: version, queue, workers, store use, cache hits, limits
  jobs [--limit N] [--state STATE]   recent jobs, newest first
  help [COMMAND]        this text, or a command's (also `kiln COMMAND --help`)

global options (anywhere on the line):
  --server ADDR         HOST:PORT ([::1]:7878 for IPv6) or unix:PATH; default $KILN_SERVER, else 127.0.0.1:7878
  --token-file FILE     the token, from the first line of FILE that is not blank or a # comment; default
                        $KILN_TOKEN, else the file named by $KILN_TOKEN_FILE. TCP needs a token; on a Unix socket
                        the socket's file permissions decide and the token is not needed.
  --version             print the client's version

Progress goes to stderr: a bar redrawn in place on a terminal, otherwise plain lines (one per 10 % of progress, at
most one a second, and one at least every 30 s). Job ids, summaries and tables go to stdout.

exit status:
  0  the job succeeded (cancel: the job is cancelled; status, jobs: the server answered)
  1  the job failed or was cancelled (result, fetch: or has not finished yet)
  2  usage error: bad flags, an unreadable or malformed job file, a job field the server refused, an unknown job id
  3  no connection, the token refused, another server error, or the outputs could not be written
)";

constexpr const char* kSubmitHelp = R"(usage: kiln submit JOB.textproto [--wait] [--out DIR] [--priority N]
                   [--idempotency-key KEY]

Submits the job in JOB.textproto (a kiln.v1.JobSpec in protobuf text format; "-" reads standard input). Without
--wait or --out, prints the job id on stdout and returns at once; follow it with `kiln watch ID`.

  --wait                 follow the job until it ends, with progress; the exit status says how it ended
  --out DIR              wait, then write every output (by its name) and report.json into DIR, created if missing
  --priority N           higher runs first, [-100, 100]; default 0
  --idempotency-key KEY  at most 128 bytes; submitting the same key and spec again returns the first job instead
                         of a new one (a retried CI step does not bake twice)

Errors in the file are reported with its line and column, including fields the server refuses.
Images a job reads (environment { image { sha256: ... size: ... } }) are blobs the server must already hold;
`kiln bake env IMAGE` uploads a local file and submits in one step.
Examples: client/examples/*.textproto. See `kiln --help` for --server, --token-file and the exit status.
)";

constexpr const char* kWatchHelp = R"(usage: kiln watch ID

Follows job ID until it ends: state, fraction done, ETA, samples and error estimate on stderr (a bar on a terminal,
plain lines otherwise). A broken connection is re-attached for about a minute. Ctrl-C stops watching; the job goes
on. On success prints what the bake cost; fetch the outputs with `kiln fetch ID --out DIR`.
Exit status 0 if the job succeeded, 1 if it failed or was cancelled.
)";

constexpr const char* kResultHelp = R"(usage: kiln result ID [--json]

Prints the outcome of finished job ID: its state (and why it failed), what it cost (samples, rays, seconds, error
estimate, cache hit), the planner's decisions, and each output with its size, media type, colour space and SHA-256.
  --json   print the same as JSON instead (the shape of the report.json that `kiln fetch` writes when the server
           sends no report of its own)
Exit status 0 if the job succeeded, 1 if it failed, was cancelled or has not finished.
)";

constexpr const char* kFetchHelp = R"(usage: kiln fetch ID --out DIR

Writes every output of finished job ID into DIR (created if missing), each under its output name, and report.json.
Each file's bytes are verified against the SHA-256 digest in the result before the file is kept.
Exit status 0 when all were written, 1 if the job failed, was cancelled or has not finished, 3 on a server or
write error.
)";

constexpr const char* kCancelHelp = R"(usage: kiln cancel ID

Cancels job ID if it is queued or running. Exit status 0 if the job is cancelled (now or before), 1 if it had
already succeeded or failed.
)";

constexpr const char* kStatusHelp = R"(usage: kiln status

Prints the server's version, uptime, queue (queued, running), workers and threads, store use, cache hits, jobs
completed and failed, connections, the job types it bakes and its limits.
)";

constexpr const char* kJobsHelp = R"(usage: kiln jobs [--limit N] [--state STATE]

Lists jobs, newest first: id, state, type, priority, submission time, seconds of baking, cache hit, name.
  --limit N        at most N jobs, [1, 1000]; default the server's (100)
  --state STATE    only jobs in STATE: queued, running, succeeded, failed or cancelled
)";

// ---- Ctrl-C during `kiln bake` --------------------------------------------------------------------------------

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

struct Interrupted {};

double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// ---- Context and connection ---------------------------------------------------------------------------------

struct Context {
  std::string server;
  std::string token;
  Terminal terminal;
  std::ostream& out;
  std::ostream& err;
  std::optional<Client> client;
  v1::HelloReply hello;
};

std::string read_token_file(const std::string& path, const std::string& source) {
  std::ifstream in(path);
  if (!in) throw UsageError(source + " " + path + ": cannot read the token file: " + std::strerror(errno));
  for (std::string line; std::getline(in, line);) {
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    const auto last = line.find_last_not_of(" \t\r");
    return line.substr(first, last - first + 1);
  }
  throw UsageError(source + " " + path + ": the token file holds no token (blank lines and # comments are skipped)");
}

// A server's error for people: "field: message (CODE)", the field only once (kilnd's messages may start with it).
std::string said(const ServerError& e) {
  const std::string& m = e.message();
  const bool named = e.field().empty() || m.rfind(e.field() + ":", 0) == 0;
  return (named ? "" : e.field() + ": ") + m + " (" + v1::Error::Code_Name(e.code()) + ")";
}

// Connects and says hello; a ConnectionError is left to the caller (who may retry), everything else becomes a
// message for people.
void connect_raw(Context& ctx) {
  ctx.client.reset();
  client::Options options;
  options.client_name = "kiln-cli 0.1.0";
  try {
    Client c(ctx.server, options);
    ctx.hello = c.hello(ctx.token);
    ctx.client.emplace(std::move(c));
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--server: ") + e.what());
  } catch (const ServerError& e) {
    if (e.code() == v1::Error::UNAUTHENTICATED) {
      throw Failure(kExitServer,
                    "kilnd at " + ctx.server + " refused this client: " + e.message() +
                        (ctx.token.empty() ? "; no token was given: pass --token-file FILE or set KILN_TOKEN"
                                           : "; check the token (--token-file FILE or KILN_TOKEN) against the "
                                             "server's token file"));
    }
    throw Failure(kExitServer, "kilnd at " + ctx.server + " refused the connection: " + said(e));
  }
}

Client& connected(Context& ctx) {
  if (ctx.client && ctx.client->is_open()) return *ctx.client;
  try {
    connect_raw(ctx);
  } catch (const ConnectionError& e) {
    throw Failure(kExitServer, "cannot talk to kilnd at " + ctx.server + ": " + e.what() +
                                   ". Is kilnd running there? Choose the server with --server HOST:PORT, "
                                   "--server unix:PATH or KILN_SERVER");
  }
  return *ctx.client;
}

// A server error on a request about job `id`, for people.
[[noreturn]] void job_request_failed(const Context& ctx, const ServerError& e, const std::string& id,
                                     const std::string& what) {
  if (e.code() == v1::Error::NOT_FOUND) {
    throw Failure(kExitUsage, "kilnd at " + ctx.server + " has no job '" + id + "' (" + e.message() +
                                  "); list the jobs it has with `kiln jobs`");
  }
  if (e.code() == v1::Error::INVALID_ARGUMENT) {
    throw Failure(kExitUsage, "kilnd at " + ctx.server + " refused to " + what + " '" + id + "': " + said(e));
  }
  throw Failure(kExitServer, "kilnd at " + ctx.server + " could not " + what + " '" + id + "': " + said(e));
}

[[noreturn]] void connection_lost(const Context& ctx, const ConnectionError& e, const std::string& what) {
  throw Failure(kExitServer, "lost the connection to kilnd at " + ctx.server + " while " + what + ": " + e.what());
}

// ---- Following a job and writing its outputs -----------------------------------------------------------------

// Follows job `id` until it ends, showing progress on stderr, and returns the final event. A broken connection is
// re-attached (the first event of a watch is the job's current state, so nothing is missed).
v1::JobEvent follow(Context& ctx, const std::string& id, bool cancel_on_interrupt) {
  ProgressPrinter printer(ctx.err, ctx.terminal.progress_in_place, ctx.terminal.columns);
  int reconnects = 0;
  for (;;) {
    std::string why;
    try {
      if (!ctx.client || !ctx.client->is_open()) connect_raw(ctx);
      return ctx.client->watch(id, [&](const v1::JobEvent& e) {
        reconnects = 0;
        printer.update(e, now());
        if (cancel_on_interrupt && g_interrupted && !e.final()) throw Interrupted{};
      });
    } catch (const ServerError& e) {
      printer.finish();
      // UNAVAILABLE: the daemon is shutting down; it re-queues the job and a restarted one serves the watch.
      if (e.code() != v1::Error::UNAVAILABLE) job_request_failed(ctx, e, id, "watch job");
      why = "kilnd is unavailable: " + e.message();
    } catch (const ConnectionError& e) {
      printer.finish();
      why = "lost the connection: " + std::string(e.what());
    }
    ctx.client.reset();
    if (++reconnects > kMaxWatchReconnects) {
      throw Failure(kExitServer, "gave up watching job " + id + " on kilnd at " + ctx.server + " (" + why +
                                     "); the job stays on the server: `kiln watch " + id + "` follows it again");
    }
    const int wait = std::min(1 << (reconnects - 1), 16);
    ctx.err << "kiln: " << why << " (kilnd at " << ctx.server << ", watching job " << id << "); trying again in "
            << wait << " s\n"
            << std::flush;
    std::this_thread::sleep_for(std::chrono::seconds(wait));
  }
}

// Why a job that did not succeed ended so, for its Failure.
std::string ending(Context& ctx, const v1::JobEvent& final, const std::string& id) {
  std::string why = final.message();
  if (why.empty() && final.state() == v1::JOB_STATE_FAILED) {
    try {
      const v1::JobResult r = connected(ctx).result(id);
      why = r.error().message();
      if (!r.error().field().empty() && why.rfind(r.error().field() + ":", 0) != 0) {
        why = r.error().field() + ": " + why;
      }
    } catch (const std::exception&) {
      // The event already says it failed; the reason is a courtesy.
    }
  }
  return "job " + id + " " + state_name(final.state()) + (why.empty() ? "" : ": " + why);
}

void write_file_atomically(const fs::path& path, const std::string& bytes) {
  const fs::path tmp = path.parent_path() / ("." + path.filename().string() + ".kiln-part");
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    f.close();
    if (!f) {
      const std::string why = std::strerror(errno);
      std::error_code ignored;
      fs::remove(tmp, ignored);
      throw Failure(kExitServer, "cannot write " + path.string() + ": " + why);
    }
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) throw Failure(kExitServer, "cannot write " + path.string() + ": " + ec.message());
}

fs::path prepare_out_dir(const std::string& dir) {
  if (dir.empty()) throw UsageError("--out: expected a folder, got ''");
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir)) {
    throw UsageError("--out " + dir + ": cannot create the folder: " +
                     (ec ? ec.message() : std::string("a file of that name is in the way")));
  }
  return fs::path(dir);
}

struct Saved {
  std::string name;
  std::uint64_t size = 0;
  std::string description;
};

// Fetches every output of `r` into `dir` and writes report.json. A file is only kept once its bytes matched the
// digest (the client library verifies them as they arrive; the file is written aside and renamed at the end).
std::vector<Saved> save_outputs(Context& ctx, const v1::JobResult& r, const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& o : r.outputs()) {
    if (!is_plain_file_name(o.name())) {
      throw Failure(kExitServer, "kilnd named an output of job " + r.job_id() + " " + json_string(o.name()) +
                                     ", which is not a plain file name; nothing was written");
    }
    if (std::find(names.begin(), names.end(), o.name()) != names.end()) {
      throw Failure(kExitServer, "kilnd sent two outputs of job " + r.job_id() + " named " + o.name() +
                                     "; nothing was written");
    }
    names.push_back(o.name());
  }
  ProgressPrinter printer(ctx.err, ctx.terminal.progress_in_place, ctx.terminal.columns);
  std::vector<Saved> saved;
  for (const auto& o : r.outputs()) {
    const fs::path path = dir / o.name();
    const fs::path tmp = dir / ("." + o.name() + ".kiln-part");
    for (int attempt = 0;; ++attempt) {
      std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
      if (!f) throw Failure(kExitServer, "cannot write " + tmp.string() + ": " + std::strerror(errno));
      try {
        connected(ctx).fetch(
            o.digest(),
            [&](std::string_view data) {
              f.write(data.data(), static_cast<std::streamsize>(data.size()));
              if (!f) throw Failure(kExitServer, "cannot write " + tmp.string() + ": " + std::strerror(errno));
            },
            [&](std::uint64_t done, std::uint64_t total) { printer.transfer(o.name(), done, total, now()); });
        f.close();
        if (!f) throw Failure(kExitServer, "cannot write " + tmp.string() + ": " + std::strerror(errno));
        break;
      } catch (const ConnectionError& e) {
        f.close();
        if (attempt + 1 >= kMaxFetchRetries) {
          std::error_code ignored;
          fs::remove(tmp, ignored);
          printer.finish();
          connection_lost(ctx, e, "fetching " + o.name() + " of job " + r.job_id());
        }
        ctx.client.reset();  // fetch again on a new connection
      } catch (const ServerError& e) {
        f.close();
        std::error_code ignored;
        fs::remove(tmp, ignored);
        printer.finish();
        if (e.code() == v1::Error::DATA_LOSS) {
          throw Failure(kExitServer, "the bytes of " + o.name() + " of job " + r.job_id() +
                                         " did not match their digest (" + e.message() + "); nothing was kept of "
                                         "it. Try `kiln fetch " + r.job_id() + " --out " + dir.string() + "` again");
        }
        if (e.code() == v1::Error::NOT_FOUND) {
          throw Failure(kExitServer, "kilnd at " + ctx.server + " no longer holds " + o.name() + " of job " +
                                         r.job_id() + " (" + e.message() + "); submit the job again to bake it");
        }
        throw Failure(kExitServer, "kilnd at " + ctx.server + " could not send " + o.name() + " of job " +
                                       r.job_id() + ": " + said(e));
      } catch (...) {
        f.close();
        std::error_code ignored;
        fs::remove(tmp, ignored);
        throw;
      }
    }
    std::error_code ec;
    fs::rename(tmp, path, ec);
    if (ec) throw Failure(kExitServer, "cannot write " + path.string() + ": " + ec.message());
    saved.push_back({o.name(), o.digest().size(), o.description()});
  }
  printer.finish();
  if (auto report = report_json_for(r)) {
    write_file_atomically(dir / "report.json", *report);
    saved.push_back({"report.json", report->size(), "the bake report (JSON)"});
  }
  return saved;
}

void print_outputs_table(std::ostream& out, const std::vector<Saved>& files) {
  std::size_t width = 0;
  for (const auto& f : files) width = std::max(width, f.name.size());
  for (const auto& f : files) {
    out << "    " << std::left << std::setw(static_cast<int>(width)) << f.name << "  " << std::right << std::setw(10)
        << format_bytes(f.size) << (f.description.empty() ? "" : "  " + f.description) << "\n";
  }
}

void print_summary(Context& ctx, const v1::JobResult& r, bool cache_hit, const std::optional<fs::path>& dir,
                   const std::vector<Saved>& saved) {
  std::ostream& out = ctx.out;
  out << "job " << r.job_id() << " " << state_name(r.state()) << (r.name().empty() ? "" : ": " + r.name()) << "\n";
  out << "  cost: " << cost_line(r, cache_hit || r.report().cache_hit()) << "\n";
  if (dir) {
    const std::string shown = dir->string();
    out << "  outputs in " << shown << (shown.back() == '/' ? ":\n" : "/:\n");
    print_outputs_table(out, saved);
  } else {
    std::vector<Saved> listed;
    for (const auto& o : r.outputs()) listed.push_back({o.name(), o.digest().size(), o.description()});
    out << "  outputs (write them into a folder with `kiln fetch " << r.job_id() << " --out DIR`):\n";
    print_outputs_table(out, listed);
  }
  out << std::flush;
}

// After the final event: on success, the result (and the outputs into `dir`); otherwise a Failure with status 1.
int conclude(Context& ctx, const v1::JobEvent& final, const std::string& id, const std::optional<fs::path>& dir,
             bool cache_hit) {
  if (final.state() != v1::JOB_STATE_SUCCEEDED) throw Failure(kExitJobFailed, ending(ctx, final, id));
  v1::JobResult r;
  try {
    r = connected(ctx).result(id);
  } catch (const ServerError& e) {
    job_request_failed(ctx, e, id, "give the result of job");
  } catch (const ConnectionError& e) {
    connection_lost(ctx, e, "asking for the result of job " + id);
  }
  std::vector<Saved> saved;
  if (dir) saved = save_outputs(ctx, r, *dir);
  print_summary(ctx, r, cache_hit, dir, saved);
  return kExitOk;
}

// Submits, naming in an error what the user wrote: `where` maps a field path to "FILE:LINE:COL" or "--flag".
v1::SubmitReply submit(Context& ctx, const v1::JobSpec& spec, std::int32_t priority, const std::string& key,
                       const std::function<std::string(const std::string&)>& where) {
  try {
    return connected(ctx).submit(spec, priority, key);
  } catch (const ServerError& e) {
    if (e.code() == v1::Error::INVALID_ARGUMENT) {
      std::string at = e.field().empty() ? "" : where(e.field());
      if (e.field() == "priority") at = "--priority";
      if (e.field() == "idempotency_key") at = "--idempotency-key";
      const bool named = e.field().empty() || e.message().rfind(e.field() + ":", 0) == 0;
      throw Failure(kExitUsage, (at.empty() ? "" : at + ": ") + "the server refused the job: " +
                                    (named ? "" : e.field() + ": ") + e.message());
    }
    if (e.code() == v1::Error::RESOURCE_EXHAUSTED) {
      throw Failure(kExitServer, "kilnd at " + ctx.server + " cannot take the job now: " + e.message() +
                                     "; try again when its queue has room (`kiln status`)");
    }
    throw Failure(kExitServer, "kilnd at " + ctx.server + " could not take the job: " + said(e));
  } catch (const ConnectionError& e) {
    connection_lost(ctx, e, "submitting the job");
  }
}

std::int32_t priority_of(const Flags& f) {
  auto v = f.get("--priority");
  return v ? static_cast<std::int32_t>(parse_whole("--priority", *v, -100, 100)) : 0;
}

std::string idempotency_key_of(const Flags& f) {
  const std::string key = f.get("--idempotency-key").value_or("");
  if (key.size() > kMaxIdempotencyKeyBytes) {
    throw UsageError("--idempotency-key: at most " + std::to_string(kMaxIdempotencyKeyBytes) + " bytes, got " +
                     std::to_string(key.size()));
  }
  return key;
}

std::string single_id(const Flags& f, const std::string& command) {
  if (f.positional.empty()) throw UsageError("missing job id: `" + command + " ID` (list jobs with `kiln jobs`)");
  if (f.positional.size() > 1) {
    throw UsageError("unexpected argument '" + f.positional[1] + "': `" + command + "` takes one job id");
  }
  const std::string& id = f.positional[0];
  // Ids are at most 64 bytes (kiln.proto); refusing here names the mistake better than the server could.
  if (id.empty() || id.size() > 64) throw UsageError("job id '" + id + "': expected 1 to 64 characters");
  return id;
}

std::vector<FlagSpec> with_globals(std::vector<FlagSpec> specs) {
  for (auto& g : global_flag_specs()) specs.push_back(std::move(g));
  return specs;
}

// ---- The commands ------------------------------------------------------------------------------------------

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
  std::optional<fs::path> dir;
  if (auto out = f.get("--out")) dir = prepare_out_dir(*out);
  const std::string label = path == "-" ? "<stdin>" : path;

  const v1::SubmitReply reply = submit(ctx, spec, priority, key, [&](const std::string& field) {
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
  const v1::JobEvent final = follow(ctx, id, false);
  return conclude(ctx, final, id, dir, reply.cache_hit());
}

// Submits `spec`, follows it with Ctrl-C cancelling it on the server, and concludes (writing into `dir` if given).
int bake_and_follow(Context& ctx, const v1::JobSpec& spec, const Flags& f, const std::optional<fs::path>& dir,
                    const std::function<std::string(const std::string&)>& where) {
  const v1::SubmitReply reply = submit(ctx, spec, priority_of(f), idempotency_key_of(f), where);
  const std::string& id = reply.job_id();
  ctx.err << "kiln: submitted job " << id << (reply.cache_hit() ? " (a cache hit: already done)" : "") << "\n";
  std::signal(SIGINT, on_interrupt);
  v1::JobEvent final;
  try {
    final = follow(ctx, id, true);
  } catch (const Interrupted&) {
    std::signal(SIGINT, SIG_DFL);  // from here on Ctrl-C just quits
    v1::JobState state;
    try {
      state = connected(ctx).cancel(id);
    } catch (const ServerError& e) {
      job_request_failed(ctx, e, id, "cancel job");
    } catch (const ConnectionError& e) {
      connection_lost(ctx, e, "cancelling job " + id);
    }
    if (state != v1::JOB_STATE_CANCELLED) {
      ctx.err << "kiln: job " << id << " had already " << state_name(state) << "\n";
      final.set_state(state);
      return conclude(ctx, final, id, dir, reply.cache_hit());
    }
    throw Failure(kExitJobFailed, "job " + id + " cancelled (Ctrl-C)" +
                                      (dir ? "; nothing was written to " + dir->string() : std::string()));
  }
  std::signal(SIGINT, SIG_DFL);
  return conclude(ctx, final, id, dir, reply.cache_hit());
}

// `kiln bake env|lightmap`: with --out or --wait, submit and follow; without, submit, print the job id and return.
int submit_then_follow(Context& ctx, const v1::JobSpec& spec, const Flags& f, const std::optional<fs::path>& dir,
                       const std::function<std::string(const std::string&)>& where) {
  if (!dir && !f.has("--wait")) {
    const v1::SubmitReply reply = submit(ctx, spec, priority_of(f), idempotency_key_of(f), where);
    ctx.out << reply.job_id() << "\n" << std::flush;
    ctx.err << "kiln: submitted job " << reply.job_id() << " (" << state_name(reply.state())
            << (reply.cache_hit() ? ", a cache hit: already done" : "") << "); follow it with `kiln watch "
            << reply.job_id() << "`, write its outputs with `kiln fetch " << reply.job_id() << " --out DIR`\n";
    return kExitOk;
  }
  return bake_and_follow(ctx, spec, f, dir, where);
}

int cmd_bake_env(Context& ctx, const Flags& f) {
  EnvironmentBake bake = environment_bake_from_flags(f);
  priority_of(f);
  idempotency_key_of(f);  // usage errors before any upload
  std::optional<fs::path> dir;
  if (auto out = f.get("--out")) dir = prepare_out_dir(*out);
  for (const std::string& file : bake.files) {
    std::error_code ec;
    if (!fs::is_regular_file(file, ec)) {
      throw UsageError(file + ": no such file (the environment to bake: an equirectangular EXR, HDR, PNG or JPEG)");
    }
  }
  std::vector<v1::Digest> digests;
  {
    ProgressPrinter printer(ctx.err, ctx.terminal.progress_in_place, ctx.terminal.columns);
    for (const std::string& file : bake.files) {
      const std::string label = fs::path(file).filename().string();
      try {
        digests.push_back(connected(ctx).upload_file(
            file, [&](std::uint64_t done, std::uint64_t total) { printer.transfer("upload " + label, done, total, now()); }));
      } catch (const ServerError& e) {
        printer.finish();
        throw Failure(kExitServer, "kilnd at " + ctx.server + " refused the upload of " + file + ": " + said(e));
      } catch (const ConnectionError& e) {
        printer.finish();
        connection_lost(ctx, e, "uploading " + file);
      } catch (const std::runtime_error& e) {
        printer.finish();
        throw Failure(kExitUsage, e.what());
      }
    }
    printer.finish();
  }
  if (!bake.files.empty()) set_input_digests(bake, digests);

  // The server names the image's field; the user named a file.
  auto where = [&](const std::string& field) -> std::string {
    for (std::size_t i = 0; i < bake.files.size(); ++i) {
      const std::string face = "job.environment.faces.digests[" + std::to_string(i) + "]";
      if (field.rfind("job.environment.image", 0) == 0 || field.rfind(face, 0) == 0) return bake.files[i];
    }
    return flag_for_field(field);
  };
  return submit_then_follow(ctx, bake.spec, f, dir, where);
}

int cmd_bake_lightmap(Context& ctx, const Flags& f) {
  LightmapBake bake = lightmap_bake_from_flags(f);
  priority_of(f);
  idempotency_key_of(f);  // usage errors before any import or upload
  std::optional<fs::path> dir;
  if (auto out = f.get("--out")) dir = prepare_out_dir(*out);
  for (const std::string& file : {bake.scene_file, bake.env_file}) {
    std::error_code ec;
    if (!file.empty() && !fs::is_regular_file(file, ec)) {
      throw UsageError(file + ": no such file (" +
                       (file == bake.scene_file ? "the scene to bake: glTF, OBJ or FBX"
                                                : "the environment: an equirectangular EXR, HDR, PNG or JPEG") + ")");
    }
  }
  client::ImportedScene scene;
  try {
    scene = client::import_scene(bake.scene_file);
  } catch (const std::exception& e) {
    throw Failure(kExitUsage, e.what());
  }
  for (const std::string& w : scene.warnings) ctx.err << "kiln: " << bake.scene_file << ": " << w << "\n";
  ctx.err << "kiln: " << bake.scene_file << ": " << scene.job.meshes_size() << " meshes, "
          << scene.job.instances_size() << " instances, " << scene.job.materials_size() << " materials, "
          << scene.job.textures_size() << " textures, " << scene.job.lights_size() << " lights\n";
  merge_scene(bake, scene.job);
  {
    // Every blob once (the importer keys them by digest); the client asks the server first and sends only what it
    // lacks.
    ProgressPrinter printer(ctx.err, ctx.terminal.progress_in_place, ctx.terminal.columns);
    std::uint64_t total = 0, sent = 0;
    for (const auto& [sha, bytes] : scene.blobs) total += bytes.size();
    const std::string label = "upload " + fs::path(bake.scene_file).filename().string();
    try {
      for (const auto& [sha, bytes] : scene.blobs) {
        connected(ctx).upload_blob(bytes, [&](std::uint64_t done, std::uint64_t) {
          printer.transfer(label, sent + done, total, now());
        });
        sent += bytes.size();
      }
      if (!bake.env_file.empty()) {
        const std::string env_label = "upload " + fs::path(bake.env_file).filename().string();
        *bake.spec.mutable_lightmap()->mutable_environment()->mutable_image() = connected(ctx).upload_file(
            bake.env_file, [&](std::uint64_t done, std::uint64_t all) { printer.transfer(env_label, done, all, now()); });
      }
    } catch (const ServerError& e) {
      printer.finish();
      throw Failure(kExitServer, "kilnd at " + ctx.server + " refused the upload of " + bake.scene_file + ": " + said(e));
    } catch (const ConnectionError& e) {
      printer.finish();
      connection_lost(ctx, e, "uploading " + bake.scene_file);
    } catch (const std::runtime_error& e) {
      printer.finish();
      throw Failure(kExitUsage, e.what());
    }
    printer.finish();
  }
  // The server names a field; the user wrote a flag, a scene file, an image or a job file.
  auto where = [&](const std::string& field) { return lightmap_field_origin(bake, field); };
  return submit_then_follow(ctx, bake.spec, f, dir, where);
}

int cmd_bake(Context& ctx, const Flags& f) {
  if (f.positional.empty()) {
    throw UsageError("missing job type: `kiln bake material ...` or `kiln bake env ...` (see `kiln bake material "
                     "--help`, `kiln bake env --help`)");
  }
  if (f.positional[0] == "env" || f.positional[0] == "environment") return cmd_bake_env(ctx, f);
  if (f.positional[0] == "lightmap") return cmd_bake_lightmap(ctx, f);
  if (f.positional[0] != "material") {
    throw UsageError("unknown job type '" + f.positional[0] +
                     "': `kiln bake` bakes material, env or lightmap (see `kiln bake material --help`, `kiln bake env "
                     "--help`, `kiln bake lightmap --help`)");
  }
  if (f.positional.size() > 1) {
    throw UsageError("unexpected argument '" + f.positional[1] + "' (see `kiln bake material --help`)");
  }
  const v1::JobSpec spec = material_spec_from_flags(f);
  priority_of(f);
  idempotency_key_of(f);
  const auto out = f.get("--out");
  if (!out) throw UsageError("--out: missing; bake writes its outputs into a folder: add --out DIR");
  const fs::path dir = prepare_out_dir(*out);
  return bake_and_follow(ctx, spec, f, dir, [](const std::string& field) { return flag_for_field(field); });
}

int cmd_watch(Context& ctx, const Flags& f) {
  const std::string id = single_id(f, "kiln watch");
  connected(ctx);
  return conclude(ctx, follow(ctx, id, false), id, std::nullopt, false);
}

void print_result(Context& ctx, const v1::JobResult& r) {
  std::ostream& out = ctx.out;
  if (r.state() != v1::JOB_STATE_SUCCEEDED) {
    out << "job " << r.job_id() << " " << state_name(r.state()) << (r.name().empty() ? "" : ": " + r.name()) << "\n";
    if (r.has_error()) {
      out << "  error: " << (r.error().field().empty() ? "" : r.error().field() + ": ") << r.error().message()
          << " (" << v1::Error::Code_Name(r.error().code()) << ")\n";
    }
  } else {
    out << "job " << r.job_id() << " succeeded" << (r.name().empty() ? "" : ": " + r.name()) << "\n";
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
  out << "  submitted " << format_time(r.submitted_unix()) << ", finished " << format_time(r.finished_unix())
      << "\n";
}

// The result of job `id`, or a Failure that says why not; `unfinished_hint` ends the message for an unfinished job.
v1::JobResult request_result(Context& ctx, const std::string& id, const std::string& unfinished_hint) {
  try {
    return connected(ctx).result(id);
  } catch (const ServerError& e) {
    if (e.code() == v1::Error::FAILED_PRECONDITION) {
      throw Failure(kExitJobFailed, "job " + id + " has not finished (" + e.message() + "); `kiln watch " + id +
                                        "` waits for it" + unfinished_hint);
    }
    job_request_failed(ctx, e, id, "give the result of job");
  } catch (const ConnectionError& e) {
    connection_lost(ctx, e, "asking for the result of job " + id);
  }
  return {};  // not reached: the handlers above throw
}

int cmd_result(Context& ctx, const Flags& f) {
  const std::string id = single_id(f, "kiln result");
  const v1::JobResult r = request_result(ctx, id, "");
  if (f.has("--json")) {
    ctx.out << result_json(r) << std::flush;
  } else {
    print_result(ctx, r);
  }
  if (r.state() == v1::JOB_STATE_SUCCEEDED) return kExitOk;
  throw Failure(kExitJobFailed, "job " + id + " " + state_name(r.state()) +
                                    (r.error().message().empty() ? "" : ": " + r.error().message()));
}

int cmd_fetch(Context& ctx, const Flags& f) {
  const std::string id = single_id(f, "kiln fetch");
  const auto out = f.get("--out");
  if (!out) throw UsageError("--out: missing; fetch writes the outputs into a folder: add --out DIR");
  const fs::path dir = prepare_out_dir(*out);
  const v1::JobResult r = request_result(ctx, id, ", or `kiln submit --out` next time");
  if (r.state() != v1::JOB_STATE_SUCCEEDED) {
    throw Failure(kExitJobFailed, "job " + id + " " + state_name(r.state()) +
                                      (r.error().message().empty() ? "" : ": " + r.error().message()) +
                                      "; it has no outputs to fetch");
  }
  const auto saved = save_outputs(ctx, r, dir);
  print_summary(ctx, r, false, dir, saved);
  return kExitOk;
}

int cmd_cancel(Context& ctx, const Flags& f) {
  const std::string id = single_id(f, "kiln cancel");
  v1::JobState state;
  try {
    state = connected(ctx).cancel(id);
  } catch (const ServerError& e) {
    job_request_failed(ctx, e, id, "cancel job");
  } catch (const ConnectionError& e) {
    connection_lost(ctx, e, "cancelling job " + id);
  }
  if (state == v1::JOB_STATE_CANCELLED) {
    ctx.out << "job " << id << " cancelled\n";
    return kExitOk;
  }
  throw Failure(kExitJobFailed, "job " + id + " had already " + state_name(state) + "; it was not cancelled");
}

int cmd_status(Context& ctx, const Flags&) {
  v1::ServerStatus s;
  try {
    s = connected(ctx).status();
  } catch (const ServerError& e) {
    throw Failure(kExitServer, "kilnd at " + ctx.server + " could not tell its status: " + said(e));
  } catch (const ConnectionError& e) {
    connection_lost(ctx, e, "asking for its status");
  }
  const v1::HelloReply& h = ctx.hello;
  const v1::Limits& l = h.limits();
  std::ostream& out = ctx.out;
  out << "kilnd at " << ctx.server << ": " << (s.server_version().empty() ? h.server_version() : s.server_version())
      << ", protocol " << h.protocol_version() << ", up " << format_duration(s.uptime_seconds()) << "\n";
  out << "  jobs: " << s.queued() << " queued, " << s.running() << " running, " << s.jobs_completed()
      << " completed, " << s.jobs_failed() << " failed, " << s.cache_hits() << " cache hits\n";
  out << "  workers: " << s.workers() << ", threads: " << s.threads() << ", connections: " << s.connections()
      << "\n";
  out << "  store: " << format_bytes(s.store_bytes())
      << (s.store_limit_bytes() ? " of " + format_bytes(s.store_limit_bytes()) : std::string(" (no limit)")) << "\n";
  std::string types;
  for (const auto& t : h.job_types()) types += (types.empty() ? "" : ", ") + t;
  out << "  job types: " << (types.empty() ? "-" : types) << "\n";
  out << "  limits: frame " << format_bytes(l.max_frame_bytes()) << ", chunk " << format_bytes(l.max_chunk_bytes())
      << ", blob " << format_bytes(l.max_blob_bytes()) << ", queue " << l.max_queued_jobs() << " jobs, heartbeat "
      << l.heartbeat_seconds() << " s\n"
      << std::flush;
  return kExitOk;
}

int cmd_jobs(Context& ctx, const Flags& f) {
  if (!f.positional.empty()) throw UsageError("unexpected argument '" + f.positional[0] + "' (see `kiln jobs --help`)");
  std::uint32_t limit = 0;
  if (auto v = f.get("--limit")) limit = static_cast<std::uint32_t>(parse_whole("--limit", *v, 1, 1000));
  v1::JobState state = v1::JOB_STATE_UNSPECIFIED;
  if (auto v = f.get("--state")) {
    bool found = false;
    for (int s = v1::JOB_STATE_QUEUED; s <= v1::JOB_STATE_CANCELLED; ++s) {
      if (*v == state_name(s)) {
        state = static_cast<v1::JobState>(s);
        found = true;
      }
    }
    if (!found) {
      throw UsageError("--state: expected one of queued, running, succeeded, failed, cancelled, got '" + *v + "'");
    }
  }
  v1::JobList list;
  try {
    list = connected(ctx).list_jobs(limit, state);
  } catch (const ServerError& e) {
    throw Failure(e.code() == v1::Error::INVALID_ARGUMENT ? kExitUsage : kExitServer,
                  "kilnd at " + ctx.server + " could not list its jobs: " + said(e));
  } catch (const ConnectionError& e) {
    connection_lost(ctx, e, "listing jobs");
  }
  if (list.jobs().empty()) {
    ctx.err << "kiln: kilnd at " << ctx.server << " has no jobs" << (f.has("--state") ? " in that state" : "")
            << "\n";
    return kExitOk;
  }
  std::size_t id_width = 2;
  for (const auto& j : list.jobs()) id_width = std::max(id_width, j.job_id().size());
  std::ostream& out = ctx.out;
  out << std::left << std::setw(static_cast<int>(id_width)) << "ID" << "  " << std::setw(10) << "STATE"
      << std::setw(13) << "TYPE" << std::right << std::setw(4) << "PRI" << "  " << std::left << std::setw(20)
      << "SUBMITTED" << std::right << std::setw(12) << "BAKING" << "  " << std::left << std::setw(6) << "CACHE"
      << "NAME\n";
  for (const auto& j : list.jobs()) {
    out << std::left << std::setw(static_cast<int>(id_width)) << j.job_id() << "  " << std::setw(10)
        << state_name(j.state()) << std::setw(13) << (j.type().empty() ? "-" : j.type()) << std::right
        << std::setw(4) << j.priority() << "  " << std::left << std::setw(20) << format_time(j.submitted_unix())
        << std::right << std::setw(12) << format_duration(j.seconds()) << "  " << std::left << std::setw(6)
        << (j.cache_hit() ? "hit" : "-") << j.name() << "\n";
  }
  out << std::flush;
  return kExitOk;
}

struct Command {
  const char* name;
  const char* help;
  std::vector<FlagSpec> flags;  // besides the global ones
  int (*run)(Context&, const Flags&);
};

const std::vector<Command>& commands() {
  static const std::vector<Command> kCommands = {
      {"submit", kSubmitHelp, {{"--wait", false}, {"--out"}, {"--priority"}, {"--idempotency-key"}}, cmd_submit},
      {"bake", kBakeMaterialHelp, {}, cmd_bake},
      {"watch", kWatchHelp, {}, cmd_watch},
      {"result", kResultHelp, {{"--json", false}}, cmd_result},
      {"fetch", kFetchHelp, {{"--out"}}, cmd_fetch},
      {"cancel", kCancelHelp, {}, cmd_cancel},
      {"status", kStatusHelp, {}, cmd_status},
      {"jobs", kJobsHelp, {{"--limit"}, {"--state"}}, cmd_jobs},
  };
  return kCommands;
}

const Command* find_command(const std::string& name) {
  for (const auto& c : commands()) {
    if (name == c.name) return &c;
  }
  return nullptr;
}

std::string command_names() {
  std::string names;
  for (const auto& c : commands()) names += (names.empty() ? "" : ", ") + std::string(c.name);
  return names;
}

int run(const std::vector<std::string>& args, Context& ctx) {
  // The command is the first word that is neither a global flag nor its value.
  std::optional<std::size_t> at;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--server" || a == "--token-file") {
      ++i;
      continue;
    }
    if (a == "--") break;
    if (a.empty() || a[0] != '-' || a == "-") {
      at = i;
      break;
    }
    if (a == "--help" || a == "-h") {
      ctx.out << kHelp;
      return kExitOk;
    }
    if (a == "--version") {
      ctx.out << kVersion << "\n";
      return kExitOk;
    }
    if (a.rfind("--server=", 0) == 0 || a.rfind("--token-file=", 0) == 0) continue;
    throw UsageError("unknown option " + a + " before the command (see `kiln --help`)");
  }
  if (!at) throw UsageError("missing command: expected one of " + command_names() + " (see `kiln --help`)");
  const std::string name = args[*at];
  std::vector<std::string> rest(args.begin(), args.begin() + static_cast<std::ptrdiff_t>(*at));
  rest.insert(rest.end(), args.begin() + static_cast<std::ptrdiff_t>(*at) + 1, args.end());

  if (name == "help") {
    std::vector<std::string> words;
    for (const auto& w : rest) {
      if (!w.empty() && w[0] != '-') words.push_back(w);
    }
    if (words.empty()) {
      ctx.out << kHelp;
      return kExitOk;
    }
    const Command* c = find_command(words[0]);
    if (!c) throw UsageError("no command '" + words[0] + "': expected one of " + command_names());
    const bool env = words[0] == "bake" && words.size() > 1 && (words[1] == "env" || words[1] == "environment");
    const bool lightmap = words[0] == "bake" && words.size() > 1 && words[1] == "lightmap";
    ctx.out << (env ? kBakeEnvHelp : lightmap ? kBakeLightmapHelp : c->help);
    return kExitOk;
  }
  const Command* command = find_command(name);
  if (!command) {
    throw UsageError("unknown command '" + name + "': expected one of " + command_names() + " (see `kiln --help`)");
  }
  // `kiln bake TYPE`: the type is the first word that is not a flag (global flags' values skipped).
  const std::string bake_type = name != "bake" ? "" : [&]() -> std::string {
    for (std::size_t i = 0; i < rest.size(); ++i) {
      if (rest[i] == "--server" || rest[i] == "--token-file") {
        ++i;
        continue;
      }
      if (!rest[i].empty() && rest[i][0] != '-') return rest[i];
    }
    return "";
  }();
  const bool bake_env = bake_type == "env" || bake_type == "environment";
  const bool bake_lightmap = bake_type == "lightmap";
  // --help wins over everything else on the line, so that a half-typed command can still ask for its help.
  for (const auto& a : rest) {
    if (a == "--") break;
    if (a == "--help" || a == "-h") {
      ctx.out << (bake_env ? kBakeEnvHelp : bake_lightmap ? kBakeLightmapHelp : command->help);
      return kExitOk;
    }
  }
  const std::string full = name == "bake" ? (bake_env        ? "kiln bake env"
                                             : bake_lightmap ? "kiln bake lightmap"
                                                             : "kiln bake material")
                                          : "kiln " + name;
  const Flags flags = parse_flags(rest,
                                  name == "bake" ? (bake_env        ? bake_env_flag_specs()
                                                    : bake_lightmap ? bake_lightmap_flag_specs()
                                                                    : bake_material_flag_specs())
                                                 : with_globals(command->flags),
                                  full);

  if (auto s = flags.get("--server")) {
    ctx.server = *s;
  } else if (const char* env = std::getenv("KILN_SERVER"); env && *env) {
    ctx.server = env;
  } else {
    ctx.server = kDefaultServer;
  }
  if (auto t = flags.get("--token-file")) {
    ctx.token = read_token_file(*t, "--token-file");
  } else if (const char* env = std::getenv("KILN_TOKEN"); env && *env) {
    ctx.token = env;
  } else if (const char* file = std::getenv("KILN_TOKEN_FILE"); file && *file) {
    ctx.token = read_token_file(file, "KILN_TOKEN_FILE");
  }
  return command->run(ctx, flags);
}

}  // namespace

int run_kiln(const std::vector<std::string>& args, std::ostream& out, std::ostream& err, const Terminal& terminal) {
  Context ctx{{}, {}, terminal, out, err, std::nullopt, {}};
  try {
    return run(args, ctx);
  } catch (const UsageError& e) {
    err << "kiln: " << e.what() << "\n";
    return kExitUsage;
  } catch (const Failure& e) {
    err << "kiln: " << e.what() << "\n";
    return e.status();
  } catch (const ConnectionError& e) {
    err << "kiln: lost the connection to kilnd at " << ctx.server << ": " << e.what() << "\n";
    return kExitServer;
  } catch (const ServerError& e) {
    err << "kiln: kilnd at " << ctx.server << " answered with an error: " << said(e) << "\n";
    return e.code() == v1::Error::INVALID_ARGUMENT ? kExitUsage : kExitServer;
  } catch (const std::exception& e) {
    err << "kiln: " << e.what() << "\n";
    return kExitServer;
  }
}

}  // namespace kiln::cli
