// Job records in SQLite: what was submitted, its state, its result, and the result cache's index.
//
// The store keeps opaque bytes (the serialized job spec and result) and plain fields; the daemon translates them to
// and from protobuf. Durability: WAL journal with synchronous=FULL (see job_db.cpp for why), so a submit or state
// change that returned has survived kill -9 and power loss alike.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "daemon/store/blob_store.h"
#include "daemon/store/job_records.h"

namespace kiln::store {

enum class JobState { queued, running, succeeded, failed, cancelled };
std::string_view to_string(JobState s);  // "queued", "running", …: the spelling stored in the database
std::optional<JobState> parse_job_state(std::string_view s);
inline bool is_terminal(JobState s) { return s != JobState::queued && s != JobState::running; }

// A stored result reused for a new submit (a cache hit).
struct CachedResult {
  std::string source_job_id;                // the job whose bake produced it
  std::string result;                       // the result as the new job should report it (serialized)
  std::vector<std::string> output_digests;  // blobs the result refers to
};

struct NewJob {
  std::string name;      // for people; may be empty
  std::string type;      // "material", "environment", …; required
  std::string spec;      // the serialized job spec (opaque)
  std::string spec_key;  // the cache key: digest of the canonical spec plus the baker version; required
  int32_t priority = 0;  // higher runs first
  std::optional<std::string> idempotency_key;  // a second insert with the same key returns the first job
  std::vector<std::string> input_digests;      // blobs the job reads (64 lowercase hex digits each)
  // Set for a cache hit: the job is recorded as succeeded at once with this result, and never queued.
  std::optional<CachedResult> cached;
};

struct JobRecord {
  std::string id;   // 32 lowercase hex digits (128 random bits), never reused
  int64_t seq = 0;  // arrival order, strictly increasing
  std::string name, type;
  std::string spec;  // empty in list() and results_by_last_used(), which leave payloads out
  std::string spec_key;
  int32_t priority = 0;
  JobState state = JobState::queued;
  double submitted = 0;  // seconds since the Unix epoch
  std::optional<double> started, finished;
  std::string error;   // why it failed; empty otherwise
  std::string result;  // the serialized result once succeeded (empty in list() and results_by_last_used())
  std::optional<std::string> idempotency_key;
  std::vector<std::string> input_digests, output_digests;
  double last_used = 0;                     // last submit, cache hit or fetch; orders result eviction
  int32_t attempts = 0;                     // times it started running; counts runs that a crash interrupted
  std::optional<std::string> cache_source;  // set when this job was answered from the result cache
  std::optional<double> evicted;            // when its outputs were evicted; such a result can no longer be fetched
};

struct InsertOutcome {
  JobRecord job;
  bool created = true;  // false: the idempotency key was known, and `job` is the job it named
};

struct JobCounts {
  uint64_t queued = 0, running = 0, succeeded = 0, failed = 0, cancelled = 0;
  uint64_t cache_hits = 0;  // succeeded jobs answered from the cache
};

struct Recovery {
  std::vector<JobRecord> queued;   // to run again, in queue order (priority, then arrival)
  std::vector<JobRecord> gave_up;  // were running at too many crashes in a row; now failed, with the reason
};

struct JobDbOptions {
  // A job that was running when the daemon died this many times is failed rather than run again, so that a job
  // which crashes the daemon cannot crash it forever. 0 retries without limit. kilnd's max_crash_restarts setting.
  int max_crash_restarts = 3;
};

// Thread-safe: one connection, guarded by a mutex. Only one process may open a database at a time (a lock file
// next to it says so); a second gets a clear error instead of two daemons running the same jobs.
class JobDb : public JobRecords {
 public:
  static constexpr int kSchemaVersion = 1;

  // Opens or creates the database file (its directory must exist) and migrates its schema. Throws StoreError:
  // failed_precondition if another process holds it or it was written by a newer kilnd, data_loss if the file is not
  // a database, io otherwise. Never deletes or rewrites a file it does not understand.
  explicit JobDb(const std::filesystem::path& file, JobDbOptions options = {});
  ~JobDb() override;
  JobDb(const JobDb&) = delete;
  JobDb& operator=(const JobDb&) = delete;

  const std::filesystem::path& file() const { return file_; }
  int schema_version();

  // Records a new job: queued, or succeeded at once if job.cached is set. With an idempotency key already in use
  // for the same spec_key, returns that job with created = false; for a different spec_key, throws already_exists.
  // invalid_argument for a missing type or spec_key, a malformed digest, or an empty or over-long key.
  InsertOutcome insert(const NewJob& job) override;
  std::optional<JobRecord> get(std::string_view id) override;
  std::optional<JobRecord> find_by_idempotency_key(std::string_view key);
  // The result cache: the newest succeeded job with this key whose outputs have not been evicted.
  std::optional<JobRecord> find_succeeded_by_spec_key(std::string_view spec_key) override;

  // State changes. Each returns the updated record; not_found for an unknown id; failed_precondition (naming the
  // job's current state) for a change its state does not allow:
  JobRecord mark_running(std::string_view id) override;  // queued → running; counts an attempt
  JobRecord mark_succeeded(std::string_view id, std::string_view result,
                           const std::vector<std::string>& output_digests) override;  // running → succeeded
  JobRecord mark_failed(std::string_view id, std::string_view error) override;        // queued or running → failed
  JobRecord mark_cancelled(std::string_view id) override;                             // queued or running → cancelled
  JobRecord mark_queued(std::string_view id) override;  // running → queued (a graceful shutdown hands it back)

  // Newest first, without spec and result; only `state` if given; only seq < before_seq if given (paging).
  std::vector<JobRecord> list(size_t limit, std::optional<JobState> state = {},
                              std::optional<int64_t> before_seq = {}) override;
  // At startup: every job that was running when the daemon stopped goes back to queued (or, after
  // max_crash_restarts interrupted runs, to failed). Returns what the queue must hold.
  Recovery recover_unfinished();
  JobCounts counts() override;
  // Marks a job's result as used (a cache hit or a fetch). Returns false for an unknown id.
  bool touch(std::string_view id, std::optional<double> when = {}) override;

  // --- Retention ---
  // Succeeded, not yet evicted results, least recently used first, without spec and result.
  std::vector<JobRecord> results_by_last_used(size_t limit);
  // Blobs that queued and running jobs read: eviction must keep them.
  std::unordered_set<std::string> pinned_digests();
  // For every blob a job refers to (input or output), the latest last_used of those jobs.
  std::unordered_map<std::string, double> blob_last_used();
  // Marks as evicted every succeeded result that refers to one of these (removed) blobs, so the cache stops
  // answering with it and a fetch says why. Returns how many.
  size_t mark_results_evicted(const std::unordered_set<std::string>& removed_digests) override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::filesystem::path file_;
  JobDbOptions options_;
  std::mutex mu_;
};

// Digest lists as comma-separated lowercase hex: plain text, readable with the sqlite3 shell and redis-cli alike.
std::string join_digests(const std::vector<std::string>& digests);
std::vector<std::string> split_digests(const std::string& joined);

// What an insert refuses before it touches the store (a missing type or spec_key, an empty or over-long idempotency
// key, a malformed digest): throws StoreError(invalid_argument) naming the field. The farm's job records use it too.
void check_new_job(const NewJob& job);

// A new job id: 128 bits from the operating system's random source, as 32 lowercase hex digits.
std::string new_job_id();
// Seconds since the Unix epoch, the unit of every time in the database.
double unix_now();

}  // namespace kiln::store
