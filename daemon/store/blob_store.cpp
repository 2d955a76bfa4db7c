#include "daemon/store/blob_store.h"

#include <fcntl.h>
#include <sys/file.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <random>
#include <tuple>

#include "daemon/store/crash_point.h"
#include "daemon/store/sha256.h"

namespace fs = std::filesystem;

namespace kiln::store {

std::string_view to_string(StoreErrc code) {
  switch (code) {
    case StoreErrc::invalid_argument:
      return "invalid argument";
    case StoreErrc::not_found:
      return "not found";
    case StoreErrc::already_exists:
      return "already exists";
    case StoreErrc::failed_precondition:
      return "failed precondition";
    case StoreErrc::out_of_range:
      return "out of range";
    case StoreErrc::data_loss:
      return "data loss";
    case StoreErrc::resource_exhausted:
      return "resource exhausted";
    case StoreErrc::io:
      return "I/O error";
    case StoreErrc::unavailable:
      return "unavailable";
  }
  return "unknown";
}

BlobId make_blob_id(std::string_view digest, uint64_t size) {
  if (!is_sha256_hex(digest)) {
    std::string shown(digest.substr(0, 80));
    throw StoreError(StoreErrc::invalid_argument, "blob digest '" + shown +
                                                      "' is not a SHA-256 digest: expected 64 hex digits, got " +
                                                      std::to_string(digest.size()) + " characters");
  }
  BlobId id{std::string(digest), size};
  for (char& c : id.digest)
    if (c >= 'A' && c <= 'F') c = static_cast<char>(c - 'A' + 'a');
  return id;
}

namespace {

std::string describe(const BlobId& id) { return "blob " + id.digest + " (" + std::to_string(id.size) + " bytes)"; }

// A full disk is worth telling apart: the operator can act on it.
StoreErrc errc_for(int err) { return (err == ENOSPC || err == EDQUOT) ? StoreErrc::resource_exhausted : StoreErrc::io; }

[[noreturn]] void throw_errno(int err, const std::string& what) {
  std::string msg = what + ": " + std::strerror(err);
  if (err == ENOSPC || err == EDQUOT) msg += kDiskFullAdvice;
  throw StoreError(errc_for(err), msg);
}

bool is_lower_hex_digest(std::string_view s) {
  if (s.size() != 64) return false;
  return std::all_of(s.begin(), s.end(), [](char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'); });
}

struct FileStat {
  bool exists = false;
  bool regular = false;
  uint64_t size = 0;
  double mtime = 0;  // seconds since the Unix epoch
};

FileStat stat_path(const fs::path& p) {
  struct stat st {};
  FileStat out;
  if (::stat(p.c_str(), &st) != 0) {
    if (errno == ENOENT || errno == ENOTDIR) return out;
    throw_errno(errno, "cannot inspect " + p.string());
  }
  out.exists = true;
  out.regular = S_ISREG(st.st_mode);
  out.size = static_cast<uint64_t>(st.st_size);
  out.mtime = static_cast<double>(st.st_mtim.tv_sec) + 1e-9 * static_cast<double>(st.st_mtim.tv_nsec);
  return out;
}

class Fd {
 public:
  explicit Fd(int fd) : fd_(fd) {}
  ~Fd() {
    if (fd_ >= 0) ::close(fd_);
  }
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  int get() const { return fd_; }
  // close() reports deferred write errors (NFS, quotas); callers that wrote must check it.
  int close() {
    int r = ::close(fd_);
    fd_ = -1;
    return r;
  }

 private:
  int fd_;
};

// A partial upload opened and held under an exclusive flock, so that nodes sharing the store (each with its own
// stripes) never interleave their appends, a completion, a discard or a sweep on it. The file found at the path
// after the lock is taken must be the one locked: a holder that was waited for may have renamed it into place or
// deleted it, and a write to that file would land in an installed blob or nowhere. On NFS, Linux takes flock as a
// byte-range lock of the whole file on the server (NLM or NFSv4), so it holds across machines too.
enum class PartialLock { held, absent, busy };
PartialLock lock_partial(const fs::path& part, bool create, bool wait, int* fd_out) {
  for (;;) {
    const int fd = ::open(part.c_str(), O_RDWR | O_CLOEXEC | (create ? O_CREAT : 0), 0644);
    if (fd < 0) {
      if (errno == ENOENT) return PartialLock::absent;
      throw_errno(errno, "cannot open partial upload " + part.string());
    }
    Fd guard(fd);
    int r;
    while ((r = ::flock(fd, LOCK_EX | (wait ? 0 : LOCK_NB))) != 0 && errno == EINTR) {
    }
    if (r != 0) {
      if (errno == EWOULDBLOCK) return PartialLock::busy;
      throw_errno(errno, "cannot lock partial upload " + part.string());
    }
    struct stat held {}, now {};
    if (::fstat(fd, &held) == 0 && ::stat(part.c_str(), &now) == 0 && held.st_ino == now.st_ino &&
        held.st_dev == now.st_dev) {
      *fd_out = ::dup(fd);  // the lock belongs to the open file, which the duplicate keeps open
      if (*fd_out < 0) throw_errno(errno, "cannot keep partial upload " + part.string() + " open");
      return PartialLock::held;
    }
  }
}

uint64_t size_of(int fd, const fs::path& file) {
  struct stat st {};
  if (::fstat(fd, &st) != 0) throw_errno(errno, "cannot inspect " + file.string());
  return static_cast<uint64_t>(st.st_size);
}

// Writes everything or throws; `written` reports how far it got, for resumable uploads.
void pwrite_all(int fd, std::string_view data, uint64_t offset, const fs::path& file, uint64_t* written) {
  size_t done = 0;
  while (done < data.size()) {
    ssize_t n = ::pwrite(fd, data.data() + done, data.size() - done, static_cast<off_t>(offset + done));
    if (n < 0) {
      if (errno == EINTR) continue;
      if (written) *written = done;
      throw_errno(errno, "cannot write " + file.string());
    }
    done += static_cast<size_t>(n);
  }
  if (written) *written = done;
}

void fsync_or_throw(int fd, const fs::path& file) {
  if (::fsync(fd) != 0) throw_errno(errno, "cannot sync " + file.string() + " to disk");
}

// A rename or a new directory entry is durable only once its directory is synced.
void fsync_dir(const fs::path& dir) {
  int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) throw_errno(errno, "cannot open directory " + dir.string() + " to sync it");
  Fd guard(fd);
  if (::fsync(fd) != 0 && errno != EINVAL) throw_errno(errno, "cannot sync directory " + dir.string());
}

void create_dir(const fs::path& p) {
  std::error_code ec;
  fs::create_directories(p, ec);
  if (ec)
    throw StoreError(StoreErrc::io, "cannot create store directory " + p.string() + ": " + ec.message() +
                                        "; check the --store path and its permissions");
  if (!fs::is_directory(p, ec))
    throw StoreError(StoreErrc::io, "store path " + p.string() +
                                        " exists but is not a directory; "
                                        "point --store at a directory");
}

double now_seconds() {
  timespec ts{};
  ::clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

std::string unique_suffix() {
  static std::atomic<uint64_t> counter{0};
  static const uint64_t salt = [] {
    std::random_device rd;
    return (uint64_t{rd()} << 32) ^ rd();
  }();
  return std::to_string(::getpid()) + "-" + std::to_string(salt ^ counter.fetch_add(1));
}

}  // namespace

BlobStore::BlobStore(fs::path dir, BlobStoreOptions options) : dir_(std::move(dir)), options_(options) {
  create_dir(dir_);
  create_dir(dir_ / "blobs");
  create_dir(dir_ / "partial");
  create_dir(dir_ / "tmp");
  if (options_.tmp_subdir != "tmp") create_dir(dir_ / options_.tmp_subdir);
  create_dir(dir_ / "corrupt");
  // Whole-file writes that a crash interrupted: never renamed into place, so nobody was told they exist. A file
  // whose writer (named in it) is another live process is left alone, in case two daemons were pointed here; the
  // job database's lock then stops the second one.
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir_ / options_.tmp_subdir, ec)) {
    std::string name = e.path().filename().string();
    long pid = 0;
    if (name.size() > 65 && name[64] == '.') pid = std::strtol(name.c_str() + 65, nullptr, 10);
    bool writer_alive = pid > 0 && pid != ::getpid() && (::kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM);
    if (!writer_alive) fs::remove_all(e.path(), ec);
  }
  // Partial uploads stay: their clients resume them.
}

fs::path BlobStore::blob_path(const std::string& digest) const { return dir_ / "blobs" / digest.substr(0, 2) / digest; }

fs::path BlobStore::partial_path(const std::string& digest) const { return dir_ / "partial" / (digest + ".part"); }

void BlobStore::check_declared(const BlobId& id) const {
  // Digests become file names: anything but lowercase hex could escape the store directory.
  if (!is_lower_hex_digest(id.digest))
    throw StoreError(StoreErrc::invalid_argument,
                     "blob digest '" + id.digest.substr(0, 80) + "' is not 64 lowercase hex digits (a SHA-256)");
  if (id.size > options_.max_blob_size)
    throw StoreError(StoreErrc::invalid_argument, describe(id) + " is larger than this store accepts (" +
                                                      std::to_string(options_.max_blob_size) + " bytes)");
}

std::mutex& BlobStore::stripe(const std::string& digest) {
  unsigned v = std::stoul(digest.substr(0, 2), nullptr, 16);
  return stripes_[v % stripes_.size()];
}

bool BlobStore::contains(const BlobId& id) const {
  check_declared(id);
  FileStat st = stat_path(blob_path(id.digest));
  return st.exists && st.regular && st.size == id.size;
}

uint64_t BlobStore::received(const BlobId& id) {
  check_declared(id);
  std::lock_guard lock(stripe(id.digest));
  if (contains(id)) return id.size;
  fs::path part = partial_path(id.digest);
  int fd = -1;
  if (lock_partial(part, false, true, &fd) != PartialLock::held) return 0;
  Fd file(fd);
  const uint64_t have = size_of(fd, part);
  if (have > id.size) {
    // Longer than this declaration: it came from an upload that declared another size, and cannot be a prefix of
    // this blob. It holds nothing anyone was promised, so start over.
    if (::ftruncate(fd, 0) != 0) throw_errno(errno, "cannot empty " + part.string());
    return 0;
  }
  return have;
}

uint64_t BlobStore::append(const BlobId& id, uint64_t offset, std::string_view data) {
  check_declared(id);
  std::lock_guard lock(stripe(id.digest));
  if (contains(id)) {
    if (offset == id.size && data.empty()) return id.size;
    throw StoreError(StoreErrc::failed_precondition,
                     describe(id) + " is already stored complete; there is nothing left to upload");
  }
  fs::path part = partial_path(id.digest);
  // Held until the chunk is written: another node appending, completing or sweeping the same digest waits.
  // Absent only when there is nothing to write (no file is created for an empty append).
  int fd = -1;
  lock_partial(part, !data.empty(), true, &fd);
  Fd file(fd);
  // Under the lock, again: a node we waited for may have completed the blob (its partial renamed into place).
  if (fd >= 0 && contains(id)) {
    std::error_code ec;
    fs::remove(part, ec);  // what this open made, or another upload's leftover: a complete blob needs neither
    throw StoreError(StoreErrc::failed_precondition,
                     describe(id) + " is already stored complete; there is nothing left to upload");
  }
  uint64_t have = fd >= 0 ? size_of(fd, part) : 0;
  if (have > id.size) {  // see received()
    if (::ftruncate(fd, 0) != 0) throw_errno(errno, "cannot empty " + part.string());
    have = 0;
  }
  if (offset != have)
    throw StoreError(StoreErrc::failed_precondition, "upload of " + describe(id) + ": a chunk arrived for offset " +
                                                         std::to_string(offset) + ", but " + std::to_string(have) +
                                                         " bytes have been received; resume from offset " +
                                                         std::to_string(have));
  if (data.size() > id.size - offset)
    throw StoreError(StoreErrc::out_of_range, "upload of " + describe(id) + ": a chunk of " +
                                                  std::to_string(data.size()) + " bytes at offset " +
                                                  std::to_string(offset) + " would go past the declared size");
  if (data.empty()) return offset;
  uint64_t written = 0;
  try {
    pwrite_all(fd, data, offset, part, &written);
  } catch (const StoreError& e) {
    // Whatever reached the file counts as received; say where to resume.
    throw StoreError(e.code(), std::string(e.what()) + " (upload of " + describe(id) + " can resume from offset " +
                                   std::to_string(offset + written) + ")");
  }
  if (file.close() != 0) throw_errno(errno, "cannot write " + part.string());
  crash_point("blob.append");
  return offset + data.size();
}

void BlobStore::install(const fs::path& from, const BlobId& id) {
  fs::path target = blob_path(id.digest);
  fs::path shard = target.parent_path();
  std::error_code ec;
  if (fs::create_directory(shard, ec)) fsync_dir(dir_ / "blobs");
  if (ec) throw StoreError(StoreErrc::io, "cannot create " + shard.string() + ": " + ec.message());
  if (::rename(from.c_str(), target.c_str()) != 0)
    throw_errno(errno, "cannot move " + from.string() + " into place as " + target.string());
  fsync_dir(shard);
  crash_point("blob.installed");
}

void BlobStore::complete(const BlobId& id) {
  check_declared(id);
  std::lock_guard lock(stripe(id.digest));
  fs::path part = partial_path(id.digest);
  // The empty blob has no chunks to append: its (empty) partial is made here, so it goes the way of any other.
  int fd = -1;
  const PartialLock got_lock = lock_partial(part, id.size == 0 && !contains(id), true, &fd);
  Fd file(fd);
  std::error_code ec;
  if (contains(id)) {
    if (got_lock == PartialLock::held) fs::remove(part, ec);  // a second upload of a blob someone finished first
    return;
  }
  const uint64_t have = fd >= 0 ? size_of(fd, part) : 0;
  if (have < id.size)
    throw StoreError(StoreErrc::failed_precondition, "upload of " + describe(id) +
                                                         " is not finished: " + std::to_string(have) +
                                                         " bytes received; send the rest from offset " +
                                                         std::to_string(have) + " before completing it");
  FileDigest got = sha256_file(part);
  if (got.digest != id.digest || got.size != id.size) {
    fs::remove(part, ec);
    throw StoreError(StoreErrc::data_loss,
                     "upload of " + describe(id) + " was rejected: the " + std::to_string(got.size) +
                         " bytes received hash to " + got.digest +
                         ", so they are not this blob. The upload was discarded; upload the blob again from offset 0");
  }
  fsync_or_throw(fd, part);
  crash_point("blob.complete");
  install(part, id);  // still under the lock: a node waiting to append finds the blob complete
}

void BlobStore::discard_partial(const BlobId& id) {
  check_declared(id);
  std::lock_guard lock(stripe(id.digest));
  const fs::path part = partial_path(id.digest);
  int fd = -1;
  if (lock_partial(part, false, true, &fd) != PartialLock::held) return;
  Fd file(fd);
  std::error_code ec;
  fs::remove(part, ec);
}

size_t BlobStore::remove_partials_older_than(std::chrono::seconds max_age) {
  double cutoff = now_seconds() - static_cast<double>(max_age.count());
  size_t removed = 0;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir_ / "partial", ec)) {
    std::string name = e.path().filename().string();
    if (name.size() != 64 + 5 || name.substr(64) != ".part" || !is_lower_hex_digest(name.substr(0, 64))) continue;
    std::lock_guard lock(stripe(name.substr(0, 64)));
    // A partial another node (or thread) holds is being written now: alive, whatever its age said a moment ago.
    int fd = -1;
    if (lock_partial(e.path(), false, false, &fd) != PartialLock::held) continue;
    Fd file(fd);
    struct stat st {};
    const bool stale = ::fstat(fd, &st) == 0 && static_cast<double>(st.st_mtim.tv_sec) +
                                                         1e-9 * static_cast<double>(st.st_mtim.tv_nsec) <
                                                     cutoff;
    std::error_code rec;
    if (stale && fs::remove(e.path(), rec)) ++removed;
  }
  return removed;
}

BlobId BlobStore::put(std::string_view bytes) {
  BlobId id{sha256_hex(bytes), bytes.size()};
  check_declared(id);
  std::lock_guard lock(stripe(id.digest));
  if (contains(id)) {
    touch(id);
    return id;
  }
  fs::path tmp = dir_ / options_.tmp_subdir / (id.digest + "." + unique_suffix() + ".tmp");
  int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) throw_errno(errno, "cannot create " + tmp.string());
  try {
    Fd file(fd);
    pwrite_all(fd, bytes, 0, tmp, nullptr);
    fsync_or_throw(fd, tmp);
    if (file.close() != 0) throw_errno(errno, "cannot write " + tmp.string());
    crash_point("blob.put");
    install(tmp, id);
  } catch (...) {
    std::error_code ec;
    fs::remove(tmp, ec);
    throw;
  }
  return id;
}

void BlobStore::quarantine_and_throw(const BlobId& id, const std::string& why) {
  fs::path from = blob_path(id.digest);
  fs::path to = dir_ / "corrupt" / (id.digest + "." + unique_suffix());
  std::string where;
  {
    std::lock_guard lock(stripe(id.digest));
    if (::rename(from.c_str(), to.c_str()) == 0)
      where = "it was moved to " + to.string() + " and will not be served";
    else
      where = "moving it aside failed (" + std::string(std::strerror(errno)) + ")";
  }
  {
    std::lock_guard vlock(verified_mu_);
    verified_.erase(id.digest);
  }
  throw StoreError(StoreErrc::data_loss, describe(id) + " is damaged on disk: " + why + "; " + where +
                                             ". Upload it again, or re-run the job that produced it");
}

void BlobStore::verify(const BlobId& id, const fs::path& file, bool again) {
  if (!again) {
    std::lock_guard vlock(verified_mu_);
    if (verified_.count(id.digest)) return;
  }
  FileDigest got = sha256_file(file);
  if (got.size != id.size) quarantine_and_throw(id, "its file holds " + std::to_string(got.size) + " bytes");
  if (got.digest != id.digest) quarantine_and_throw(id, "its content hashes to " + got.digest);
  std::lock_guard vlock(verified_mu_);
  verified_.insert(id.digest);
}

namespace {
[[noreturn]] void throw_not_found(const BlobId& id) {
  throw StoreError(StoreErrc::not_found, describe(id) +
                                             " is not in the store; upload it (or re-run the job that "
                                             "produced it) first");
}
// Fills `out` from the file at `offset`; returns how many bytes it got (fewer where the file ends).
size_t read_at(int fd, const fs::path& file, uint64_t offset, std::string& out) {
  size_t done = 0;
  while (done < out.size()) {
    ssize_t n = ::pread(fd, out.data() + done, out.size() - done, static_cast<off_t>(offset + done));
    if (n < 0) {
      if (errno == EINTR) continue;
      throw_errno(errno, "cannot read " + file.string());
    }
    if (n == 0) break;
    done += static_cast<size_t>(n);
  }
  return done;
}

}  // namespace

void BlobStore::refuse_size(const BlobId& id, const fs::path& file) {
  FileDigest got = sha256_file(file);
  if (got.digest == id.digest)
    throw StoreError(StoreErrc::not_found, "blob " + id.digest + " is stored with " + std::to_string(got.size) +
                                               " bytes, not " + std::to_string(id.size) +
                                               "; ask for it with its real size");
  quarantine_and_throw(id, "its file holds " + std::to_string(got.size) + " bytes and hashes to " + got.digest);
}

std::string BlobStore::read(const BlobId& id) {
  check_declared(id);
  fs::path file = blob_path(id.digest);
  int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    if (errno == ENOENT) throw_not_found(id);
    throw_errno(errno, "cannot open " + file.string());
  }
  Fd guard(fd);
  struct stat st {};
  if (::fstat(fd, &st) != 0) throw_errno(errno, "cannot inspect " + file.string());
  if (static_cast<uint64_t>(st.st_size) != id.size) {
    guard.close();
    refuse_size(id, file);
  }
  std::string out(id.size, '\0');
  const size_t done = read_at(fd, file, 0, out);
  guard.close();
  // Hash what is returned, not a second read of the file: the bytes handed out are the bytes checked.
  if (done != out.size()) quarantine_and_throw(id, "its file ended after " + std::to_string(done) + " bytes");
  std::string got = sha256_hex(out);
  if (got != id.digest) quarantine_and_throw(id, "its content hashes to " + got);
  {
    std::lock_guard vlock(verified_mu_);
    verified_.insert(id.digest);
  }
  touch(id);
  return out;
}

std::string BlobStore::read_range(const BlobId& id, uint64_t offset, uint64_t length) {
  check_declared(id);
  fs::path file = blob_path(id.digest);
  FileStat st = stat_path(file);
  if (!st.exists) throw_not_found(id);
  if (st.size != id.size) refuse_size(id, file);
  if (offset > id.size)
    throw StoreError(StoreErrc::out_of_range,
                     "read of " + describe(id) + " at offset " + std::to_string(offset) + " is past its end");
  // A fetch starts at offset 0: the file is hashed then, every time, so damage is found when the blob is served,
  // whoever wrote it and whenever. The chunks that follow trust that verification instead of hashing the whole
  // blob once per chunk; a read elsewhere that is the first of this process hashes too.
  verify(id, file, /*again=*/offset == 0);
  uint64_t n_want = std::min(length, id.size - offset);
  int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    if (errno == ENOENT) throw_not_found(id);  // evicted just now
    throw_errno(errno, "cannot open " + file.string());
  }
  Fd guard(fd);
  std::string out(n_want, '\0');
  const size_t done = read_at(fd, file, offset, out);
  guard.close();
  if (done != out.size()) quarantine_and_throw(id, "its file ended after " + std::to_string(offset + done) + " bytes");
  if (offset == 0) touch(id);  // once per fetch, not once per chunk
  return out;
}

bool BlobStore::touch(const BlobId& id) {
  check_declared(id);
  // Null times mean "now"; a failure only loses recency information, never data.
  return ::utimensat(AT_FDCWD, blob_path(id.digest).c_str(), nullptr, 0) == 0;
}

namespace {
struct Entry {
  BlobId id;
  double mtime = 0;
};

std::vector<Entry> scan_blobs(const fs::path& blobs) {
  std::vector<Entry> out;
  std::error_code ec;
  for (const auto& shard : fs::directory_iterator(blobs, ec)) {
    std::string shard_name = shard.path().filename().string();
    if (shard_name.size() != 2) continue;
    std::error_code ec2;
    for (const auto& f : fs::directory_iterator(shard.path(), ec2)) {
      std::string name = f.path().filename().string();
      // Only names this store writes; anything else is not ours to count or delete.
      if (!is_lower_hex_digest(name) || name.compare(0, 2, shard_name) != 0) continue;
      FileStat st = stat_path(f.path());
      if (!st.exists || !st.regular) continue;
      out.push_back({{name, st.size}, st.mtime});
    }
  }
  return out;
}
}  // namespace

std::vector<BlobId> BlobStore::list() const {
  std::vector<BlobId> out;
  for (auto& e : scan_blobs(dir_ / "blobs")) out.push_back(std::move(e.id));
  std::sort(out.begin(), out.end(), [](const BlobId& a, const BlobId& b) { return a.digest < b.digest; });
  return out;
}

BlobUsage BlobStore::usage() const {
  BlobUsage u;
  for (const auto& e : scan_blobs(dir_ / "blobs")) {
    ++u.blob_count;
    u.blob_bytes += e.id.size;
  }
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir_ / "partial", ec)) {
    FileStat st = stat_path(e.path());
    if (!st.exists || !st.regular) continue;
    ++u.partial_count;
    u.partial_bytes += st.size;
  }
  return u;
}

uint64_t BlobStore::size_on_disk() const {
  BlobUsage u = usage();
  return u.blob_bytes + u.partial_bytes;
}

EvictionReport BlobStore::evict_to(uint64_t limit_bytes, const std::unordered_set<std::string>& pinned,
                                   const std::unordered_map<std::string, double>& last_used,
                                   const EvictConfirm& confirm) {
  std::lock_guard elock(evict_mu_);
  EvictionReport report;
  std::vector<Entry> entries = scan_blobs(dir_ / "blobs");
  uint64_t total = 0;
  for (const auto& e : entries) total += e.id.size;
  std::vector<Entry> candidates;
  for (auto& e : entries) {
    if (pinned.count(e.id.digest)) continue;
    if (auto it = last_used.find(e.id.digest); it != last_used.end()) e.mtime = it->second;
    candidates.push_back(std::move(e));
  }
  // Oldest use first; the digest only makes ties deterministic.
  std::sort(candidates.begin(), candidates.end(), [](const Entry& a, const Entry& b) {
    return std::tie(a.mtime, a.id.digest) < std::tie(b.mtime, b.id.digest);
  });
  for (const auto& c : candidates) {
    if (total <= limit_bytes) break;
    if (confirm && !confirm(c.id, c.mtime)) continue;
    std::error_code ec;
    bool removed;
    {
      std::lock_guard lock(stripe(c.id.digest));
      removed = fs::remove(blob_path(c.id.digest), ec);
    }
    if (!removed) continue;  // gone already, or undeletable: either way nothing to count
    {
      std::lock_guard vlock(verified_mu_);
      verified_.erase(c.id.digest);
    }
    total -= c.id.size;
    report.bytes_freed += c.id.size;
    report.removed.push_back(c.id);
  }
  report.bytes_after = total;
  report.limit_unreachable = total > limit_bytes;
  return report;
}

}  // namespace kiln::store
