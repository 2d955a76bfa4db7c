// The job records as the service and the workers use them: what was submitted, its state, its result, and the
// result cache's lookup. JobDb (SQLite, one node) and the farm's records in Redis (daemon/cluster/) implement it, so
// kilnd answers alike from either (docs/SCALING.md). Implementations are thread-safe.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_set>
#include <vector>

namespace kiln::store {

struct NewJob;
struct JobRecord;
struct InsertOutcome;
struct JobCounts;
enum class JobState;

class JobRecords {
 public:
  virtual ~JobRecords() = default;

  // See JobDb for each member's contract; the farm's records keep the same one.
  virtual InsertOutcome insert(const NewJob& job) = 0;
  virtual std::optional<JobRecord> get(std::string_view id) = 0;
  virtual std::optional<JobRecord> find_succeeded_by_spec_key(std::string_view spec_key) = 0;
  virtual JobRecord mark_running(std::string_view id) = 0;
  virtual JobRecord mark_succeeded(std::string_view id, std::string_view result,
                                   const std::vector<std::string>& output_digests) = 0;
  virtual JobRecord mark_failed(std::string_view id, std::string_view error) = 0;
  virtual JobRecord mark_cancelled(std::string_view id) = 0;
  virtual JobRecord mark_queued(std::string_view id) = 0;
  virtual std::vector<JobRecord> list(size_t limit, std::optional<JobState> state = {},
                                      std::optional<int64_t> before_seq = {}) = 0;
  virtual JobCounts counts() = 0;
  virtual bool touch(std::string_view id, std::optional<double> when = {}) = 0;
  virtual size_t mark_results_evicted(const std::unordered_set<std::string>& removed_digests) = 0;
};

}  // namespace kiln::store
