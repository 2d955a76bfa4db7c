// The in-memory side of running jobs: the queue that feeds the workers (higher priority first, then arrival), each
// job's cancel flag, and its latest progress with subscriptions for watchers.
//
// The database stays the record of truth (job_db.h); this is rebuilt from JobDb::recover_unfinished() at startup.
// Free of Asio and protobuf: callbacks are plain functions, and sessions post them to their own strands.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <stop_token>
#include <string>
#include <string_view>
#include <vector>

#include "daemon/store/job_db.h"

namespace kiln::store {

// A job's latest progress, as watchers see it.
struct Progress {
  JobState state = JobState::queued;
  double fraction = 0;                   // of the work done, in [0, 1]
  std::optional<double> eta_seconds;     // unknown until the baker can estimate it
  uint64_t samples = 0;                  // taken so far
  std::optional<double> error_estimate;  // current estimated error, when the baker has one
  std::string message;                   // for people: the error of a failed job, a phase name, …
};

// A job handed to a worker.
struct QueuedJob {
  std::string id;
  int32_t priority = 0;
  int64_t seq = 0;
  // Set by cancel(); the worker passes it to the baker, which stops at its next check.
  std::shared_ptr<std::atomic<bool>> cancel;
};

enum class CancelOutcome {
  removed_from_queue,  // it was waiting: it will never run
  signalled,           // it was running: its cancel flag is set, and the worker records how it ended
  unknown,             // not queued or running here (finished, or never known)
};

class JobQueue;

// A watcher's registration, removed when this handle is destroyed (or reset()).
//
// Flow control, so a slow watcher costs memory for one snapshot, not a backlog: the callback runs once, then not
// again until the watcher calls ready(); updates published meanwhile coalesce, and ready() delivers the latest one
// at once (from ready()'s caller) if there is one. So a session calls ready() when its write of the previous event
// has finished. Callbacks for one subscription never run concurrently with each other. A callback may still run
// once after the handle is destroyed, if it had already begun: capture weak pointers, not raw ones.
class Subscription {
 public:
  Subscription() = default;
  ~Subscription();
  Subscription(Subscription&&) noexcept;
  Subscription& operator=(Subscription&&) noexcept;
  Subscription(const Subscription&) = delete;
  Subscription& operator=(const Subscription&) = delete;

  void ready();
  void reset();
  explicit operator bool() const { return state_ != nullptr; }

  struct State;  // opaque: defined in job_queue.cpp

 private:
  friend class JobQueue;
  std::shared_ptr<State> state_;
};

// The queue as the service and the workers use it. JobQueue (below) is one node's; the farm's (daemon/cluster/)
// claims from Redis and keeps a JobQueue for what is only its node's business (docs/SCALING.md). See JobQueue for
// each member's contract. Implementations are thread-safe.
class WorkQueue {
 public:
  using Callback = std::function<void(const Progress&)>;
  virtual ~WorkQueue() = default;

  virtual bool push(const std::string& id, int32_t priority, int64_t seq) = 0;
  virtual std::optional<QueuedJob> pop(std::stop_token stop = {}) = 0;
  virtual CancelOutcome cancel(std::string_view id) = 0;
  virtual std::shared_ptr<std::atomic<bool>> cancel_flag(std::string_view id) = 0;
  virtual size_t size() const = 0;
  virtual size_t running() const = 0;
  virtual std::vector<std::string> running_ids() const = 0;
  virtual void shutdown() = 0;
  virtual bool is_shut_down() const = 0;
  virtual void publish(std::string_view id, Progress progress) = 0;
  virtual void finish(std::string_view id, Progress final_progress) = 0;
  virtual Subscription subscribe(std::string_view id, Callback callback) = 0;
};

// Thread-safe: any member may be called from any thread at the same time.
class JobQueue : public WorkQueue {
 public:
  JobQueue();
  ~JobQueue() override;  // shuts down; subscriptions outlive it safely (they go quiet)
  JobQueue(const JobQueue&) = delete;
  JobQueue& operator=(const JobQueue&) = delete;

  // Queues a job and starts tracking it (cancel flag, progress "queued"). Every job pushed stays tracked until
  // finish(id), whether it ran, was removed or was cancelled. Returns false, changing nothing, if the id is already
  // tracked or after shutdown().
  bool push(const std::string& id, int32_t priority, int64_t seq) override;
  // Blocks until a job is available, then returns it (it is now running, and its watchers are told so). Returns
  // nothing once `stop` is requested or the queue is shut down.
  std::optional<QueuedJob> pop(std::stop_token stop = {}) override;
  // Non-blocking pop.
  std::optional<QueuedJob> try_pop();
  // Takes a waiting job out of the queue (still tracked until finish()). False if it was not waiting.
  bool remove(std::string_view id);
  // Removes a waiting job (and sets its flag), or sets a running job's cancel flag.
  CancelOutcome cancel(std::string_view id) override;
  // The cancel flag of a queued or running job.
  std::shared_ptr<std::atomic<bool>> cancel_flag(std::string_view id) override;

  size_t size() const override;     // jobs waiting
  size_t running() const override;  // jobs popped and not yet finished
  bool is_queued(std::string_view id) const;
  std::vector<std::string> running_ids() const override;  // e.g. to signal them at a shutdown's grace deadline

  // Wakes every pop() (they return nothing) and refuses further pushes. Jobs still waiting stay queued in the
  // database and run after the next start.
  void shutdown() override;
  bool is_shut_down() const override;

  // --- Progress ---
  // Records the job's latest progress (non-finite numbers become unknown, fraction is clamped to [0, 1]) and
  // notifies its watchers. Ignored for a job that is not tracked.
  void publish(std::string_view id, Progress progress) override;
  // Publishes the final state, then stops tracking the job: later subscribe() calls get nothing, and the daemon
  // answers those from the database. Record the final state in the database first, so no watcher misses it.
  void finish(std::string_view id, Progress final_progress) override;
  std::optional<Progress> latest(std::string_view id) const;
  // Watches a tracked job; the callback receives the latest snapshot at once (from this call) and then as
  // described at Subscription. Returns an empty handle if the job is not tracked (finished or unknown).
  Subscription subscribe(std::string_view id, Callback callback) override;

  struct Impl;  // opaque: defined in job_queue.cpp

 private:
  std::shared_ptr<Impl> impl_;
};

}  // namespace kiln::store
