#include "client/cli/build_outputs.h"

#include <fcntl.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <optional>
#include <system_error>

#include "client/cli/outputs.h"
#include "client/cli/report.h"
#include "proto/digest.h"

namespace kiln::cli {
namespace {

namespace fs = std::filesystem;

// The SHA-256 of the file at `path` if its size is `size`; nullopt if it is missing, of another size or unreadable.
std::optional<std::string> digest_if_size(const fs::path& path, std::uint64_t size) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec) || fs::file_size(path, ec) != size || ec) return std::nullopt;
  std::ifstream in(path, std::ios::binary);
  proto::Sha256 hash;
  char buf[64 << 10];
  while (in.read(buf, sizeof buf).gcount() > 0)
    hash.update(std::string_view(buf, static_cast<std::size_t>(in.gcount())));
  if (in.bad()) return std::nullopt;
  return hash.finish();
}

// The new folder beside `dir`, removed unless released: a failed write leaves nothing behind.
class StagingFolder {
 public:
  explicit StagingFolder(const fs::path& dir)
      : path_(dir.parent_path() / ("." + dir.filename().string() + ".kiln-new")) {
    std::error_code ec;
    fs::remove_all(path_, ec);  // left by a build that was killed
    fs::create_directories(path_, ec);
    if (ec) throw Failure(kExitServer, "cannot create " + path_.string() + ": " + ec.message());
  }
  ~StagingFolder() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  StagingFolder(const StagingFolder&) = delete;
  StagingFolder& operator=(const StagingFolder&) = delete;
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

void fetch_into(Context& ctx, const v1::JobResult& r, const v1::Output& o, const fs::path& file) {
  std::ofstream f(file, std::ios::binary | std::ios::trunc);
  if (!f) throw Failure(kExitServer, "cannot write " + file.string() + ": " + std::strerror(errno));
  try {
    connected_client(ctx).fetch(
        o.digest(), [&](std::string_view data) { f.write(data.data(), static_cast<std::streamsize>(data.size())); });
  } catch (const client::ServerError& e) {
    throw Failure(kExitServer, "kilnd at " + ctx.server + " could not send " + o.name() + " of job " + r.job_id() +
                                   ": " + describe_server_error(e) + "; run the build again to bake it afresh");
  }
  f.close();
  if (!f) throw Failure(kExitServer, "cannot write " + file.string() + ": " + std::strerror(errno));
}

void write_bytes(const fs::path& file, const std::string& bytes) {
  std::ofstream f(file, std::ios::binary | std::ios::trunc);
  f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  f.close();
  if (!f) throw Failure(kExitServer, "cannot write " + file.string() + ": " + std::strerror(errno));
}

// Puts `staged` where `dir` is: swapped with it in one step when it exists (the old folder then goes), else renamed.
void replace_folder(const fs::path& staged, const fs::path& dir) {
  std::error_code ec;
  if (fs::exists(dir, ec)) {
    if (renameat2(AT_FDCWD, staged.c_str(), AT_FDCWD, dir.c_str(), RENAME_EXCHANGE) != 0) {
      throw Failure(kExitServer, "cannot replace " + dir.string() + ": " + std::strerror(errno));
    }
    return;  // `staged` now holds the old folder, which StagingFolder removes
  }
  fs::rename(staged, dir, ec);
  if (ec) throw Failure(kExitServer, "cannot write " + dir.string() + ": " + ec.message());
}

}  // namespace

FolderWrite write_output_folder(Context& ctx, const v1::JobResult& result, const fs::path& dir) {
  check_output_names(result);
  std::error_code ec;
  fs::create_directories(dir.parent_path(), ec);
  if (ec) throw Failure(kExitServer, "cannot create " + dir.parent_path().string() + ": " + ec.message());

  FolderWrite w;
  std::map<std::string, bool> same;  // output name -> already in `dir` with its bytes
  for (const auto& o : result.outputs()) {
    same[o.name()] = digest_if_size(dir / o.name(), o.digest().size()) == o.digest().sha256();
  }
  const std::optional<std::string> report = report_json_for(result);
  const bool report_same = report && digest_if_size(dir / "report.json", report->size()) == proto::sha256_hex(*report);
  bool all_same = !report || report_same;
  for (const auto& [name, s] : same) all_same = all_same && s;
  if (all_same) {
    w.unchanged = static_cast<int>(same.size()) + (report ? 1 : 0);
    return w;
  }

  const StagingFolder staging(dir);
  const auto keep = [&](const std::string& name) {
    // A hard link keeps the file itself: its inode and modification time, so build tools see no change.
    fs::create_hard_link(dir / name, staging.path() / name, ec);
    if (ec) fs::copy_file(dir / name, staging.path() / name, fs::copy_options::overwrite_existing, ec);
    if (ec) throw Failure(kExitServer, "cannot keep " + (dir / name).string() + ": " + ec.message());
    ++w.unchanged;
  };
  for (const auto& o : result.outputs()) {
    if (same[o.name()]) {
      keep(o.name());
    } else {
      fetch_into(ctx, result, o, staging.path() / o.name());
      ++w.written;
    }
  }
  if (report) {
    if (report_same) {
      keep("report.json");
    } else {
      write_bytes(staging.path() / "report.json", *report);
      ++w.written;
    }
  }
  replace_folder(staging.path(), dir);
  return w;
}

}  // namespace kiln::cli
