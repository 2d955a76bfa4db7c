// Content-addressed blob storage on local disk: inputs uploaded by clients and the outputs of bakes, each named by
// its SHA-256 digest and size.
//
// Layout under the store directory DIR:
//   DIR/blobs/ab/abcdef…      complete, verified blobs (the first two hex digits shard the directory)
//   DIR/partial/<digest>.part uploads in progress; an upload broken half-way resumes at the file's length. Each is
//                             touched only under an exclusive flock on it, so processes sharing DIR (a farm's
//                             nodes) never interleave their appends, completions and sweeps
//   DIR/tmp/                  whole-file writes before their rename; anything here after a crash is deleted on open
//   DIR/corrupt/              blobs that failed verification when read, kept for inspection, never served
// A blob appears under blobs/ only by an atomic rename of a file that was verified and fsynced, followed by an
// fsync of the directory, so after a crash (kill -9 or power loss) a blob is either whole or absent.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <mutex>
#include <stdexcept>
#include <string>
#include <string_view>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace kiln::store {

// What went wrong, in terms the daemon maps onto its protocol's error codes.
enum class StoreErrc {
  invalid_argument,     // malformed input: a digest that is not 64 hex digits, an offset beyond the declared size
  not_found,            // no such blob or job
  already_exists,       // an idempotency key reused for a different job
  failed_precondition,  // the request is valid but not now: completing an unfinished upload, cancelling a finished job
  out_of_range,         // an offset or length beyond the blob's (declared) size
  data_loss,            // bytes do not match their digest, or a stored file is damaged
  resource_exhausted,   // the disk is full
  io,                   // the operating system refused (permissions, I/O error)
  unavailable,          // a farm's shared service (Redis) cannot be reached now; retry, or use another node
};
std::string_view to_string(StoreErrc code);

// What a message about a full disk adds: what the operator can do.
inline constexpr char kDiskFullAdvice[] = "; free disk space or lower the store's retention limit";

// Every error of the store: a code for programs and a message for people that names what failed and what to do.
class StoreError : public std::runtime_error {
 public:
  StoreError(StoreErrc code, const std::string& message) : std::runtime_error(message), code_(code) {}
  StoreErrc code() const { return code_; }

 private:
  StoreErrc code_;
};

// A blob's name: its SHA-256 digest (64 lowercase hex digits) and its size in bytes.
struct BlobId {
  std::string digest;
  uint64_t size = 0;
  friend bool operator==(const BlobId&, const BlobId&) = default;
};
// Validates and normalises (lowercases) a digest; throws StoreError(invalid_argument) naming the bad value.
BlobId make_blob_id(std::string_view digest, uint64_t size);

struct BlobStoreOptions {
  // Declared sizes above this are refused before anything is written.
  uint64_t max_blob_size = uint64_t{64} << 30;
  // Where whole-file writes wait for their rename, under DIR, and the folder cleaned at open. A farm's nodes share
  // DIR, so each has its own ("tmp/NODE"): one node's open must not delete another's write in progress.
  std::filesystem::path tmp_subdir = "tmp";
};

struct BlobUsage {
  uint64_t blob_count = 0, blob_bytes = 0;        // complete blobs
  uint64_t partial_count = 0, partial_bytes = 0;  // uploads in progress
};

struct EvictionReport {
  std::vector<BlobId> removed;  // least recently used first
  uint64_t bytes_freed = 0;
  uint64_t bytes_after = 0;  // complete blobs left on disk
  // True when the limit could not be reached because the remaining blobs are pinned.
  bool limit_unreachable = false;
};

// Thread-safe: any member may be called from any thread at the same time.
class BlobStore {
 public:
  // Creates DIR and its subfolders if needed, and deletes leftovers in DIR/tmp (writes a crash interrupted: they
  // were never renamed into place, so no one was told they exist). Throws StoreError(io) if DIR is unusable.
  // One BlobStore per directory: open the JobDb first, whose lock keeps a second daemon out of the store.
  explicit BlobStore(std::filesystem::path dir, BlobStoreOptions options = {});
  BlobStore(const BlobStore&) = delete;
  BlobStore& operator=(const BlobStore&) = delete;

  const std::filesystem::path& dir() const { return dir_; }

  // --- Uploads (chunked, resumable) ---
  // Bytes already held for this blob: its size if complete, else the length of its partial upload, else 0.
  uint64_t received(const BlobId& id);
  // Writes `data` at `offset`, which must equal received(id) (so chunks arrive in order, and a retry of a chunk that
  // already arrived is refused with the offset to resume from); offset + data.size() must not exceed id.size.
  // Returns the new received count. Appending nothing at received(id) is allowed and changes nothing.
  uint64_t append(const BlobId& id, uint64_t offset, std::string_view data);
  // Once all bytes have arrived: verifies the SHA-256, fsyncs, and renames the partial into place. A blob that is
  // already complete is left as it is. Throws failed_precondition if bytes are missing, and data_loss if the
  // bytes do not hash to the digest (the partial is then deleted, so the upload restarts from offset 0).
  void complete(const BlobId& id);
  // Drops a partial upload (a client that gave up). Complete blobs are not touched.
  void discard_partial(const BlobId& id);
  // Deletes partial uploads untouched for longer than max_age (clients that never came back), except one that
  // another process is writing now (its flock is held). Returns how many.
  size_t remove_partials_older_than(std::chrono::seconds max_age);

  // --- Whole writes (bake results) ---
  // Stores `bytes` (tmp file → fsync → rename → fsync directory) and returns its id. Storing bytes that are already
  // present writes nothing and only marks the blob as used now.
  BlobId put(std::string_view bytes);

  // --- Reads (verified) ---
  // True if the complete blob is present with exactly this size (not a verification: reads verify).
  bool contains(const BlobId& id) const;
  // The whole blob, with its SHA-256 checked. not_found if absent; data_loss if the file is damaged (it is then
  // moved to DIR/corrupt/ so a fresh upload can replace it).
  std::string read(const BlobId& id);
  // Up to `length` bytes from `offset` (fewer at the end of the blob; none when offset == size; out_of_range beyond
  // it). The file's size is checked on every call and its content hashed at every read from offset 0 (the start of
  // a fetch) and at a first read elsewhere, so a chunked fetch hashes a blob once, not once per chunk, and damage
  // is found at the next fetch whoever wrote the file.
  std::string read_range(const BlobId& id, uint64_t offset, uint64_t length);
  // Marks a blob as used now (its modification time), for eviction when no last-used time is given for it.
  // Returns false if the blob is not stored.
  bool touch(const BlobId& id);

  // --- Accounting and retention ---
  std::vector<BlobId> list() const;
  BlobUsage usage() const;
  // Bytes of complete blobs plus partial uploads.
  uint64_t size_on_disk() const;
  // Removes unpinned blobs, least recently used first, until the complete blobs total at most limit_bytes. A blob's
  // last use is last_used[digest] (seconds since the Unix epoch) when given, else its modification time (set when it
  // was written or touched). Pinned blobs are never removed, even if the limit cannot be met without them.
  // `confirm`, if given, is asked immediately before each removal with the blob and its last use, and a false
  // answer keeps the blob (a farm checks its pins again in Redis: they may have changed since the snapshot).
  using EvictConfirm = std::function<bool(const BlobId&, double last_used)>;
  EvictionReport evict_to(uint64_t limit_bytes, const std::unordered_set<std::string>& pinned,
                          const std::unordered_map<std::string, double>& last_used,
                          const EvictConfirm& confirm = {});

 private:
  std::filesystem::path blob_path(const std::string& digest) const;
  std::filesystem::path partial_path(const std::string& digest) const;
  void check_declared(const BlobId& id) const;
  std::mutex& stripe(const std::string& digest);
  // Renames `from` (a verified, fsynced file) to the blob's place and makes the rename durable.
  void install(const std::filesystem::path& from, const BlobId& id);
  // Hashes the stored file (unless `again` is false and this process already verified it since it was last read
  // from the start); on damage, quarantines it and throws data_loss.
  void verify(const BlobId& id, const std::filesystem::path& file, bool again);
  [[noreturn]] void quarantine_and_throw(const BlobId& id, const std::string& why);
  // A stored file whose size is not id.size: either the caller has the size wrong (not_found, naming the real size)
  // or the file is damaged (quarantined, data_loss); the hash decides which.
  [[noreturn]] void refuse_size(const BlobId& id, const std::filesystem::path& file);

  std::filesystem::path dir_;
  BlobStoreOptions options_;
  // Per-digest serialisation of uploads, installs and removals, striped so unrelated blobs proceed in parallel.
  std::array<std::mutex, 64> stripes_;
  mutable std::mutex verified_mu_;
  std::unordered_set<std::string> verified_;  // digests hashed and found whole by this process
  std::mutex evict_mu_;                       // one eviction at a time
};

}  // namespace kiln::store
