// The worker's side of the farm's queue (docs/SCALING.md, "The queue"): claim the next job with a lease, renew the
// lease while baking, commit the end once, or hand the job back. Every step is one Lua script, so one round trip.
//
// Holds no connection: every call takes the caller's RedisClient (one per worker thread). RedisError when Redis
// cannot be reached: the caller keeps its claim and tries again when Redis returns.
#pragma once

#include <chrono>
#include <optional>
#include <string>
#include <vector>

#include "daemon/cluster/redis_client.h"
#include "daemon/store/job_db.h"
#include "daemon/store/job_queue.h"

namespace kiln::cluster {

// A job this worker runs, and the stream entry that is its lease.
struct Claim {
  store::JobRecord job;
  std::string consumer;  // the worker's name in the consumer group: NODE/INDEX
  std::string level;     // the priority whose stream holds the entry
  std::string entry;     // the stream entry's id
};

struct LeaseState {
  bool held = false;              // false: another worker reclaimed the job (this one was gone past the lease)
  bool cancel_requested = false;  // someone cancelled the job: stop the bake and commit it cancelled
};

enum class CommitOutcome {
  committed,  // this result is the job's
  duplicate,  // the job had ended already (another run committed first): this result was discarded and counted
};

struct FarmQueueOptions {
  std::string prefix = "kiln:";
  std::string node;                        // this kilnd's name in the farm
  std::chrono::milliseconds lease{10000};  // a claim not renewed for this long may be reclaimed by any worker
  int max_crash_restarts = 3;              // runs a job may lose to dead nodes before it is failed; 0: no limit
};

class FarmQueue {
 public:
  explicit FarmQueue(FarmQueueOptions options) : options_(std::move(options)) {}

  // The next job for worker `index` of this node: an expired lease's job first, then the highest priority's oldest.
  // The job is `running` when this returns. Nothing if no job waits.
  std::optional<Claim> claim(RedisClient& redis, int index);
  LeaseState renew(RedisClient& redis, const Claim& claim);
  CommitOutcome commit_success(RedisClient& redis, const Claim& claim, const std::string& result,
                               const std::vector<std::string>& output_digests);
  CommitOutcome commit_failure(RedisClient& redis, const Claim& claim, const std::string& error);
  CommitOutcome commit_cancelled(RedisClient& redis, const Claim& claim);
  // A graceful stop hands the job back to the farm's queue at once (not counted as a crash). False if the lease was
  // lost already.
  bool requeue(RedisClient& redis, const Claim& claim);
  // Records the job's latest progress and sends it to the watchers on every node (one round trip).
  void publish(RedisClient& redis, const std::string& id, const store::Progress& progress);

  const FarmQueueOptions& options() const { return options_; }

 private:
  CommitOutcome commit(RedisClient& redis, const Claim& claim, const char* outcome, const std::string& text,
                       const std::string& outputs);

  FarmQueueOptions options_;
};

}  // namespace kiln::cluster
