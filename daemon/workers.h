// The worker threads: each takes the next job from the queue, runs its bake and records how it ended.
#pragma once

#include <atomic>
#include <memory>
#include <thread>
#include <vector>

#include "daemon/config.h"

namespace kiln::store {
class BlobStore;
class JobDb;
class JobQueue;
}  // namespace kiln::store

namespace kiln::daemon {

class Workers {
 public:
  Workers(const Config& config, store::JobDb& db, store::BlobStore& blobs, store::JobQueue& queue);
  ~Workers();  // stop(), then join

  void start();
  // From now on a cancelled bake goes back to the queue (a shutdown), instead of ending as cancelled.
  void requeue_cancelled() { requeue_ = true; }
  // Asks the threads to stop after their current job and joins them (the queue must be shut down first).
  void join();

 private:
  void run(std::stop_token stop);
  void run_one(const std::string& id, const std::shared_ptr<std::atomic<bool>>& cancel);

  Config config_;
  store::JobDb& db_;
  store::BlobStore& blobs_;
  store::JobQueue& queue_;
  std::atomic<bool> requeue_{false};
  int threads_per_job_ = 1;
  std::vector<std::jthread> threads_;
};

}  // namespace kiln::daemon
