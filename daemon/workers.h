// The worker threads: each takes the next job from the queue, runs its bake and records how it ended.
#pragma once

#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "daemon/config.h"

namespace kiln::store {
class BlobStore;
class JobRecords;
class WorkQueue;
struct JobRecord;
}  // namespace kiln::store

namespace kiln::daemon {

struct BakeRequest;
struct Baked;  // what a bake hands back to the worker (workers.cpp)
class MemoryBudget;

class Workers {
 public:
  // A job runs once its memory estimate fits in `memory` beside the running jobs'; until then it waits (still
  // queued in the database, its watchers told why).
  Workers(const Config& config, store::JobRecords& db, store::BlobStore& blobs, store::WorkQueue& queue,
          MemoryBudget& memory);
  ~Workers();  // stop(), then join

  void start();
  // From now on a cancelled bake goes back to the queue (a shutdown), instead of ending as cancelled.
  void requeue_cancelled() { requeue_ = true; }
  // Asks the threads to stop after their current job and joins them (the queue must be shut down first).
  void join();

 private:
  void run(std::stop_token stop);
  // One job, from the queue to its end: running, baked, then succeeded, cancelled (or re-queued) or failed.
  // `admission` (held since the pop) is released once the job holds its memory or has ended.
  void run_one(const std::string& id, const std::shared_ptr<std::atomic<bool>>& cancel, std::stop_token stop,
               std::unique_lock<std::mutex>& admission);
  // Waits until the request's memory estimate fits; false (the job's end recorded) if it was cancelled meanwhile or
  // the daemon is stopping (the job then stays queued for the next start).
  bool wait_for_memory(const std::string& id, const BakeRequest& request, const std::atomic<bool>& cancel,
                       std::stop_token stop);
  // Marks the job running; nothing (and the queue told) if it was cancelled or removed meanwhile.
  std::optional<store::JobRecord> start_running(const std::string& id);
  // The job's stored spec, translated again (its blobs are not read yet).
  BakeRequest request_of(const store::JobRecord& record);
  Baked bake(const std::string& id, const BakeRequest& request, std::atomic<bool>* cancel);
  void record_success(const std::string& id, const store::JobRecord& record, const BakeRequest& request,
                      const Baked& baked, std::chrono::steady_clock::time_point t0);
  void record_cancelled(const std::string& id);
  void record_failure(const std::string& id, const std::string& what);
  // The job store cannot be reached now (a farm's Redis is down): the job is not the cause, so it is not failed but
  // handed back to the queue, to run when the store answers again.
  void hand_back(const std::string& id, const std::string& why);

  Config config_;
  store::JobRecords& db_;
  store::BlobStore& blobs_;
  store::WorkQueue& queue_;
  MemoryBudget& memory_;
  // Held from a pop until that job holds its memory: jobs take memory in the queue's order (priority, then
  // arrival), so a job waiting for room is not overtaken by one popped after it, and none waits forever.
  std::mutex admission_;
  std::atomic<bool> requeue_{false};
  int threads_per_job_ = 1;
  std::vector<std::jthread> threads_;
};

}  // namespace kiln::daemon
