// The farm's retention (docs/FARM.md, "Retention"): decided once for the whole farm by whichever node holds the
// lock PREFIXretention (SET NX PX, renewed at every blob it removes). A pass deletes the records of finished jobs
// unused for job_retention_seconds, then brings the shared store under its limit: the least recently used blobs
// first (PREFIXblob_used, else the file's time), never one that a queued or running job on any node reads
// (PREFIXpins) nor one used within eviction_grace_seconds (an output a client may be about to fetch, an input
// uploaded for a submit on its way). Each removal is confirmed by a script just before the file goes, so a pin
// taken after the pass's snapshot still saves the blob, and the results that lose it leave the cache.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

#include "daemon/cluster/redis_client.h"
#include "daemon/store/blob_store.h"

namespace kiln::cluster {

struct FarmRetentionOptions {
  std::string prefix = "kiln:";
  std::string node;                  // the lock's holder, as `redis-cli GET kiln:retention` shows it
  uint64_t store_limit_bytes = 0;    // 0: nothing is evicted
  double eviction_grace_seconds = 3600;
  double job_retention_seconds = 30 * 86400.0;  // 0: records are kept forever
  std::chrono::milliseconds lock_lease{60000};  // a node that dies mid-pass holds the lock no longer than this
};

struct FarmRetentionReport {
  bool ran = false;  // false: another node holds the lock and runs the pass
  store::EvictionReport blobs;
  size_t results_evicted = 0;
  size_t jobs_expired = 0;
};

class FarmRetention {
 public:
  FarmRetention(FarmRetentionOptions options, store::BlobStore& blobs);

  // One pass for the farm, unless another node runs one now.
  FarmRetentionReport run(RedisClient& redis);
  // Deletes the records of finished jobs last used before `cutoff` (seconds since the epoch), with their
  // idempotency keys and cache entries. Returns how many.
  size_t expire_jobs(RedisClient& redis, double cutoff);
  // A blob written anew (an upload completed): used now, and a submit naming it is no longer refused as evicted.
  void stored(RedisClient& redis, const std::string& digest);

  const FarmRetentionOptions& options() const { return options_; }

 private:
  bool lock(RedisClient& redis);
  void unlock(RedisClient& redis);
  store::EvictionReport evict(RedisClient& redis, size_t& results_evicted);
  // Asks Redis, for one blob the pass chose, whether it may go now (evict_blob script).
  bool confirm(RedisClient& redis, const store::BlobId& id, double last_used, double cutoff, bool& lost,
               size_t& results_evicted);

  FarmRetentionOptions options_;
  store::BlobStore& blobs_;
  std::string token_;  // this node's lock value: its name and a random part
};

}  // namespace kiln::cluster
