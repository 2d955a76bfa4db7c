// The farm's queue as the service and the workers use it (store::WorkQueue): pop claims from Redis (and waits for
// a wake-up when nothing is queued, or for Redis when it is away), the cancel flags and progress of the jobs this
// node runs are its local JobQueue's, and a watch of a job running elsewhere follows its events through the node's
// subscriber (docs/SCALING.md).
#pragma once

#include <atomic>
#include <memory>

#include "daemon/cluster/farm_node.h"
#include "daemon/store/job_queue.h"

namespace kiln::cluster {

class FarmWorkQueue : public store::WorkQueue {
 public:
  explicit FarmWorkQueue(std::shared_ptr<FarmNode> node) : node_(std::move(node)) {}
  ~FarmWorkQueue() override { shutdown(); }

  // The farm's insert queued the job already (on its priority's stream): nothing to do but say so.
  bool push(const std::string& id, int32_t priority, int64_t seq) override;
  std::optional<store::QueuedJob> pop(std::stop_token stop = {}) override;
  store::CancelOutcome cancel(std::string_view id) override;
  std::shared_ptr<std::atomic<bool>> cancel_flag(std::string_view id) override;
  size_t size() const override;     // queued in the whole farm
  size_t running() const override;  // running on this node
  std::vector<std::string> running_ids() const override;
  void shutdown() override;
  bool is_shut_down() const override;
  void publish(std::string_view id, store::Progress progress) override;
  // A job still claimed here that ends queued (the shutdown caught it waiting for memory) is handed back to the farm.
  void finish(std::string_view id, store::Progress final_progress) override;
  store::Subscription subscribe(std::string_view id, Callback callback) override;

 private:
  std::shared_ptr<FarmNode> node_;
  std::atomic<int> next_worker_{0};
};

}  // namespace kiln::cluster
