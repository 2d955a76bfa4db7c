#include "client/cli/outputs.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <ostream>

#include "client/cli/format.h"
#include "client/cli/progress.h"
#include "client/cli/report.h"
#include "proto/text.h"

namespace kiln::cli {
namespace {

namespace fs = std::filesystem;
using client::ConnectionError;
using client::ServerError;

// Retries of one output's fetch after a broken connection.
constexpr int kMaxFetchRetries = 3;

// The Failure for a file that could not be written, with the system's reason.
Failure cannot_write(const fs::path& path) {
  const std::string why = std::strerror(errno);
  return Failure(kExitServer, "cannot write " + path.string() + ": " + why);
}

void remove_quietly(const fs::path& path) {
  std::error_code ignored;
  fs::remove(path, ignored);
}

void rename_or_fail(const fs::path& from, const fs::path& to) {
  std::error_code ec;
  fs::rename(from, to, ec);
  if (ec) throw Failure(kExitServer, "cannot write " + to.string() + ": " + ec.message());
}

}  // namespace

void check_output_names(const v1::JobResult& r) {
  std::vector<std::string> names;
  for (const auto& o : r.outputs()) {
    if (!is_plain_file_name(o.name())) {
      throw Failure(kExitServer, "kilnd named an output of job " + r.job_id() + " " + json_string(o.name()) +
                                     ", which is not a plain file name; nothing was written");
    }
    if (std::find(names.begin(), names.end(), o.name()) != names.end()) {
      throw Failure(kExitServer,
                    "kilnd sent two outputs of job " + r.job_id() + " named " + o.name() + "; nothing was written");
    }
    names.push_back(o.name());
  }
}

namespace {

[[noreturn]] void throw_fetch_refused(const Context& ctx, const ServerError& e, const v1::JobResult& r,
                                      const std::string& name, const fs::path& dir) {
  if (e.code() == v1::Error::DATA_LOSS) {
    throw Failure(kExitServer, "the bytes of " + name + " of job " + r.job_id() + " did not match their digest (" +
                                   e.message() + "); nothing was kept of it. Try `kiln fetch " + r.job_id() +
                                   " --out " + dir.string() + "` again");
  }
  if (e.code() == v1::Error::NOT_FOUND) {
    throw Failure(kExitServer, "kilnd at " + ctx.server + " no longer holds " + name + " of job " + r.job_id() + " (" +
                                   e.message() + "); submit the job again to bake it");
  }
  throw Failure(kExitServer, "kilnd at " + ctx.server + " could not send " + name + " of job " + r.job_id() + ": " +
                                 describe_server_error(e));
}

// The bytes of output `o` into the open file `f` (the temporary `tmp`).
void stream_output(Context& ctx, const v1::Output& o, const fs::path& tmp, std::ofstream& f, ProgressPrinter& printer) {
  connected_client(ctx).fetch(
      o.digest(),
      [&](std::string_view data) {
        f.write(data.data(), static_cast<std::streamsize>(data.size()));
        if (!f) throw cannot_write(tmp);
      },
      [&](std::uint64_t done, std::uint64_t total) { printer.transfer(o.name(), done, total, steady_seconds()); });
  f.close();
  if (!f) throw cannot_write(tmp);
}

// Output `o` into `tmp`, fetched again on a new connection after a broken one; `tmp` is removed on any failure.
void fetch_output(Context& ctx, const v1::JobResult& r, const v1::Output& o, const fs::path& tmp, const fs::path& dir,
                  ProgressPrinter& printer) {
  for (int attempt = 0;; ++attempt) {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    if (!f) throw cannot_write(tmp);
    try {
      stream_output(ctx, o, tmp, f, printer);
      return;
    } catch (const ConnectionError& e) {
      f.close();
      if (attempt + 1 >= kMaxFetchRetries) {
        remove_quietly(tmp);
        printer.finish();
        throw_connection_lost(ctx, e, "fetching " + o.name() + " of job " + r.job_id());
      }
      ctx.client.reset();  // fetch again on a new connection
    } catch (const ServerError& e) {
      f.close();
      remove_quietly(tmp);
      printer.finish();
      throw_fetch_refused(ctx, e, r, o.name(), dir);
    } catch (...) {
      f.close();
      remove_quietly(tmp);
      throw;
    }
  }
}

void print_outputs_table(std::ostream& out, const std::vector<SavedFile>& files) {
  std::size_t width = 0;
  for (const auto& f : files) width = std::max(width, f.name.size());
  for (const auto& f : files) {
    out << "    " << std::left << std::setw(static_cast<int>(width)) << f.name << "  " << std::right << std::setw(10)
        << format_bytes(f.size) << (f.description.empty() ? "" : "  " + f.description) << "\n";
  }
}

}  // namespace

fs::path create_out_dir(const std::string& dir) {
  if (dir.empty()) throw UsageError("--out: expected a folder, got ''");
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir)) {
    throw UsageError("--out " + dir + ": cannot create the folder: " +
                     (ec ? ec.message() : std::string("a file of that name is in the way")));
  }
  return fs::path(dir);
}

std::optional<fs::path> out_dir_of(const Flags& f) {
  if (auto out = f.get("--out")) return create_out_dir(*out);
  return std::nullopt;
}

void write_file_atomically(const fs::path& path, const std::string& bytes) {
  const fs::path tmp = path.parent_path() / ("." + path.filename().string() + ".kiln-part");
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    f.close();
    if (!f) {
      const Failure failure = cannot_write(path);
      remove_quietly(tmp);
      throw failure;
    }
  }
  rename_or_fail(tmp, path);
}

std::vector<SavedFile> save_outputs(Context& ctx, const v1::JobResult& r, const fs::path& dir) {
  check_output_names(r);
  ProgressPrinter printer(ctx.err, ctx.terminal.progress_in_place, ctx.terminal.columns);
  std::vector<SavedFile> saved;
  for (const auto& o : r.outputs()) {
    const fs::path tmp = dir / ("." + o.name() + ".kiln-part");
    fetch_output(ctx, r, o, tmp, dir, printer);
    rename_or_fail(tmp, dir / o.name());
    saved.push_back({o.name(), o.digest().size(), o.description()});
  }
  printer.finish();
  if (auto report = report_json_for(r)) {
    write_file_atomically(dir / "report.json", *report);
    saved.push_back({"report.json", report->size(), "the bake report (JSON)"});
  }
  return saved;
}

void print_summary(Context& ctx, const v1::JobResult& r, bool cache_hit, const std::optional<fs::path>& dir,
                   const std::vector<SavedFile>& saved) {
  std::ostream& out = ctx.out;
  out << "job " << r.job_id() << " " << state_name(r.state())
      << (r.name().empty() ? "" : ": " + proto::printable(r.name())) << "\n";
  out << "  cost: " << cost_line(r, cache_hit || r.report().cache_hit()) << "\n";
  if (dir) {
    const std::string shown = dir->string();
    out << "  outputs in " << shown << (shown.back() == '/' ? ":\n" : "/:\n");
    print_outputs_table(out, saved);
  } else {
    std::vector<SavedFile> listed;
    for (const auto& o : r.outputs()) listed.push_back({o.name(), o.digest().size(), o.description()});
    out << "  outputs (write them into a folder with `kiln fetch " << r.job_id() << " --out DIR`):\n";
    print_outputs_table(out, listed);
  }
  out << std::flush;
}

}  // namespace kiln::cli
