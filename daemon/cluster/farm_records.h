// The farm's job records as the service and the workers use them (store::JobRecords over FarmJobs and the node's
// claims): a state change of a job this node runs goes through its claim (commit once, hand back), the rest reads
// and writes Redis directly. Redis out of reach: reads and submits fail with StoreError(unavailable) naming the
// server; the end of a bake waits for Redis to return, so no result is lost (docs/SCALING.md).
#pragma once

#include <memory>

#include "daemon/cluster/farm_node.h"
#include "daemon/store/job_records.h"

namespace kiln::cluster {

class FarmRecords : public store::JobRecords {
 public:
  explicit FarmRecords(std::shared_ptr<FarmNode> node) : node_(std::move(node)) {}

  store::InsertOutcome insert(const store::NewJob& job) override;
  std::optional<store::JobRecord> get(std::string_view id) override;
  std::optional<store::JobRecord> find_succeeded_by_spec_key(std::string_view spec_key) override;
  // The claim made the job running: this checks the node holds it and returns its record.
  store::JobRecord mark_running(std::string_view id) override;
  store::JobRecord mark_succeeded(std::string_view id, std::string_view result,
                                  const std::vector<std::string>& output_digests) override;
  store::JobRecord mark_failed(std::string_view id, std::string_view error) override;
  // A job this node runs: committed cancelled. Another: cancelled if still queued; already cancelled is no error
  // (the farm's cancel records a queued job's end itself).
  store::JobRecord mark_cancelled(std::string_view id) override;
  store::JobRecord mark_queued(std::string_view id) override;
  std::vector<store::JobRecord> list(size_t limit, std::optional<store::JobState> state = {},
                                     std::optional<int64_t> before_seq = {}) override;
  store::JobCounts counts() override;
  bool touch(std::string_view id, std::optional<double> when = {}) override;
  size_t mark_results_evicted(const std::unordered_set<std::string>& removed_digests) override;

 private:
  // FarmNode::call, retried until Redis answers: for the end of a bake, which must not be lost.
  template <class F>
  auto persist(F&& f);
  // The end of a job this node runs, through its claim (nothing if its lease passed to another node).
  store::JobRecord end_claimed(const Claim& claim, const char* outcome, std::string_view text,
                               const std::vector<std::string>& outputs);
  store::JobRecord current(std::string_view id);

  std::shared_ptr<FarmNode> node_;
};

}  // namespace kiln::cluster
