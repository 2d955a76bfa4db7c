#include "bakers/envmap/dfg_cache.h"

#include <algorithm>
#include <fstream>
#include <mutex>
#include <optional>
#include <random>
#include <tuple>
#include <utility>
#include <vector>

#include "bakers/bake/bounded_cache.h"
#include "bakers/envmap/dfg_file.h"

namespace kiln::envmap {
namespace {

namespace fs = std::filesystem;

std::mutex folder_mutex;
fs::path tables_folder;  // empty: tables are kept in the process only

fs::path folder() {
  const std::lock_guard<std::mutex> lock(folder_mutex);
  return tables_folder;
}

// The folder's table of `key`, if it holds exactly that table; a file that does not is left to be overwritten.
std::optional<DfgTable> read_table(const fs::path& path, const DfgKey& key) {
  std::error_code ec;
  const uintmax_t size = fs::file_size(path, ec);
  if (ec || size != dfg_encoded_size(key)) return std::nullopt;
  std::string bytes(size, '\0');
  std::ifstream in(path, std::ios::binary);
  if (!in.read(bytes.data(), static_cast<std::streamsize>(size))) return std::nullopt;
  std::optional<DfgTable> table = decode_dfg_table(bytes, key);
  if (!table || !verify_dfg_sample(*table, key)) return std::nullopt;
  fs::last_write_time(path, fs::file_time_type::clock::now(), ec);  // recently used: pruned last
  return table;
}

// Beyond kDfgFilesKept tables, the least recently used go, never `just_written` (file times are coarse: several
// tables written within a few milliseconds have the same).
void prune(const fs::path& dir, const fs::path& just_written) {
  std::vector<std::pair<fs::file_time_type, fs::path>> files;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("dfg-", 0) != 0 || e.path().extension() != ".bin" || e.path() == just_written) continue;
    files.emplace_back(e.last_write_time(ec), e.path());
  }
  if (files.size() < static_cast<size_t>(kDfgFilesKept)) return;
  std::sort(files.begin(), files.end());
  for (size_t i = 0; i + kDfgFilesKept - 1 < files.size(); ++i) fs::remove(files[i].second, ec);
}

// Written whole under a name of its own, then renamed into place, so that a reader (another process sharing the
// folder) sees the old file, no file, or the new one. The folder is a cache: a table that cannot be written is
// computed again next time, which is no error of the bake.
void write_table(const fs::path& dir, const fs::path& path, const DfgKey& key, const DfgTable& table) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  static std::mutex random_mutex;
  static std::random_device device;
  uint64_t tag;
  {
    const std::lock_guard<std::mutex> lock(random_mutex);
    tag = (static_cast<uint64_t>(device()) << 32) ^ device();
  }
  const fs::path tmp = dir / (".tmp-" + std::to_string(tag) + "-" + path.filename().string());
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    const std::string bytes = encode_dfg_table(key, table);
    if (!out.write(bytes.data(), static_cast<std::streamsize>(bytes.size())) || !out.flush()) {
      out.close();
      fs::remove(tmp, ec);
      return;
    }
  }
  fs::rename(tmp, path, ec);
  if (ec) fs::remove(tmp, ec);
  prune(dir, path);
}

DfgTable build(const DfgKey& key, DfgSource& source) {
  const fs::path dir = folder();
  const fs::path path = dir.empty() ? fs::path() : dir / dfg_file_name(key);
  if (!dir.empty()) {
    if (std::optional<DfgTable> kept = read_table(path, key)) {
      source = DfgSource::file;
      return std::move(*kept);
    }
  }
  source = DfgSource::computed;
  DfgTable table = compute_dfg(lobe_model(key.lobe, key.masking), key.size, key.size, key.options);
  if (!dir.empty()) write_table(dir, path, key, table);
  return table;
}

}  // namespace

const char* to_string(DfgSource source) {
  switch (source) {
    case DfgSource::computed:
      return "computed";
    case DfgSource::process:
      return "kept in the process";
    case DfgSource::file:
      return "kept in the store";
  }
  return "computed";
}

void keep_dfg_tables_in(const fs::path& dir) {
  const std::lock_guard<std::mutex> lock(folder_mutex);
  tables_folder = dir;
}

std::shared_ptr<const DfgTable> cached_dfg(EnvLobe lobe, brdf::Masking masking, int size,
                                           const brdf::AlbedoOptions& options, DfgSource* source) {
  const DfgKey key{lobe, masking, size, options};
  DfgSource built_from = DfgSource::process;
  if (static_cast<long long>(size) * size > kDfgCacheMaxEntries) {
    if (source) *source = DfgSource::computed;
    return std::make_shared<const DfgTable>(compute_dfg(lobe_model(lobe, masking), size, size, options));
  }
  using Key = std::tuple<int, int, int, int, int, uint64_t>;
  static bake::BoundedCache<Key, DfgTable> cache(kDfgCacheTables);
  const Key cache_key{static_cast<int>(lobe), static_cast<int>(masking), size,
                      options.samples,        options.replicates,        options.seed};
  auto table = cache.get(cache_key, [&] { return build(key, built_from); });
  if (source) *source = built_from;
  return table;
}

}  // namespace kiln::envmap
