// The farm's job records in Redis (docs/SCALING.md): what store::JobDb does for one node (insert with idempotency,
// get, the result cache's lookup, list, counts, cancel), for every node of the farm at once. Records come back as
// the same store::JobRecord, so the service answers from either store alike.
//
// Holds no connection: every call takes the caller's RedisClient (one per thread). Errors: store::StoreError for
// what the single-node store would refuse too (invalid_argument, already_exists, not_found, resource_exhausted),
// RedisError when Redis cannot be reached.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "daemon/cluster/redis_client.h"
#include "daemon/store/job_db.h"
#include "daemon/store/job_queue.h"

namespace kiln::cluster {

struct FarmCounts {
  store::JobCounts jobs;
  uint64_t duplicates = 0;  // results committed a second time (a reclaimed job that ran twice), discarded
};

class FarmJobs {
 public:
  explicit FarmJobs(std::string prefix = "kiln:") : prefix_(std::move(prefix)) {}

  // Records a new job, queued on its priority's stream (or succeeded at once for job.cached). With the job's
  // idempotency key already used for the same spec_key, returns that job (created = false). resource_exhausted
  // when the farm already holds max_queued queued jobs (0: no limit).
  store::InsertOutcome insert(RedisClient& redis, const store::NewJob& job, uint32_t max_queued);
  std::optional<store::JobRecord> get(RedisClient& redis, std::string_view id);
  std::optional<store::JobRecord> find_by_idempotency_key(RedisClient& redis, std::string_view key);
  // The result cache: the job whose result answers this key, if it succeeded and its outputs were not evicted.
  std::optional<store::JobRecord> find_succeeded_by_spec_key(RedisClient& redis, std::string_view spec_key);
  // Newest first, without spec and result; only `state` if given; only seq < before_seq if given.
  std::vector<store::JobRecord> list(RedisClient& redis, size_t limit, std::optional<store::JobState> state = {},
                                     std::optional<int64_t> before_seq = {});
  FarmCounts counts(RedisClient& redis);
  // Marks a job's result and its outputs as used at `when` (default now: a cache hit or a fetch). False for an
  // unknown id.
  bool touch(RedisClient& redis, std::string_view id, std::optional<double> when = {});
  // A queued job is cancelled at once; a running one is signalled to its node (kiln:cancel), which records the end.
  store::CancelOutcome cancel(RedisClient& redis, std::string_view id);
  // Marks as evicted every succeeded result that refers to one of these blobs (gone or damaged), so the cache stops
  // answering with it and a fetch says why. Returns how many.
  size_t mark_results_evicted(RedisClient& redis, const std::vector<std::string>& digests);
  // The job's latest progress, as its watchers on any node last saw it.
  std::optional<store::Progress> latest(RedisClient& redis, std::string_view id);

  const std::string& prefix() const { return prefix_; }

 private:
  std::string key(std::string_view kind, std::string_view name) const;
  std::optional<store::JobRecord> get_by_reply(const std::string& id, const RedisReply& hgetall);

  std::string prefix_;
};

// Job ids and keys from clients are bounded before they become Redis keys.
inline constexpr size_t kMaxKeyPartBytes = 256;

// How long after the farm's retention removed a blob a submit naming it as an input is refused (unless it was
// uploaded again): longer than any submit takes from checking its inputs' files to its insert.
inline constexpr int kEvictedInputSeconds = 60;

}  // namespace kiln::cluster
