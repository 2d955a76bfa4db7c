// The workers (daemon/workers.h) against a job store that cannot be reached for a while, as a farm's records are
// while its Redis restarts: a job whose record cannot be read is handed back to the queue, not failed with the
// store's error (the farm's test once saw a job fail with "cannot connect to Redis").
#include "daemon/workers.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "daemon/config.h"
#include "daemon/memory_budget.h"
#include "daemon/store/blob_store.h"
#include "daemon/store/job_db.h"
#include "daemon/store/job_queue.h"
#include "proto/kiln.pb.h"
#include "tests/support/eventually.h"
#include "tests/support/temp_dir.h"

namespace kiln::daemon {
namespace {

// A JobDb whose get() answers "unavailable" while `down` is set, as FarmRecords does while Redis cannot be reached.
class UnreachableRecords : public store::JobRecords {
 public:
  explicit UnreachableRecords(store::JobDb& db) : db_(db) {}
  std::atomic<bool> down{true};
  std::atomic<int> refused{0};

  std::optional<store::JobRecord> get(std::string_view id) override {
    if (down) {
      ++refused;
      throw store::StoreError(store::StoreErrc::unavailable, "cannot connect to Redis at unix:/nowhere");
    }
    return db_.get(id);
  }
  store::InsertOutcome insert(const store::NewJob& job) override { return db_.insert(job); }
  std::optional<store::JobRecord> find_succeeded_by_spec_key(std::string_view key) override {
    return db_.find_succeeded_by_spec_key(key);
  }
  store::JobRecord mark_running(std::string_view id) override { return db_.mark_running(id); }
  store::JobRecord mark_succeeded(std::string_view id, std::string_view result,
                                  const std::vector<std::string>& digests) override {
    return db_.mark_succeeded(id, result, digests);
  }
  store::JobRecord mark_failed(std::string_view id, std::string_view error) override {
    return db_.mark_failed(id, error);
  }
  store::JobRecord mark_cancelled(std::string_view id) override { return db_.mark_cancelled(id); }
  store::JobRecord mark_queued(std::string_view id) override { return db_.mark_queued(id); }
  std::vector<store::JobRecord> list(size_t limit, std::optional<store::JobState> state,
                                     std::optional<int64_t> before_seq) override {
    return db_.list(limit, state, before_seq);
  }
  store::JobCounts counts() override { return db_.counts(); }
  bool touch(std::string_view id, std::optional<double> when) override { return db_.touch(id, when); }
  size_t mark_results_evicted(const std::unordered_set<std::string>& removed) override {
    return db_.mark_results_evicted(removed);
  }

 private:
  store::JobDb& db_;
};

TEST(Workers, AJobWhoseRecordCannotBeReachedGoesBackToTheQueueInsteadOfFailing) {
  test::TempDir dir("kiln-workers");
  store::JobDb db(dir.path() / "jobs.db");
  store::BlobStore blobs(dir.path() / "blobs");
  store::JobQueue queue;
  MemoryBudget memory(uint64_t{1} << 30);
  UnreachableRecords records(db);

  v1::JobSpec spec;
  spec.mutable_material()->mutable_lambert()->mutable_albedo()->set_r(0.5);
  spec.mutable_material()->set_table_mu(2);
  spec.mutable_material()->set_table_roughness(2);
  spec.mutable_material()->set_preview(false);
  store::NewJob job;
  job.type = "material";
  spec.SerializeToString(&job.spec);
  job.spec_key = std::string(64, 'a');
  const store::JobRecord inserted = records.insert(job).job;

  ASSERT_TRUE(queue.push(inserted.id, inserted.priority, inserted.seq));
  // Every event the queue gives the job's watchers.
  std::mutex mutex;
  std::vector<store::Progress> events;
  store::Subscription watch = queue.subscribe(inserted.id, [&](const store::Progress& p) {
    const std::lock_guard<std::mutex> lock(mutex);
    events.push_back(p);
  });

  Config config;
  Workers workers(config, records, blobs, queue, memory);
  workers.start();
  ASSERT_TRUE(test::eventually(
      [&] {
        watch.ready();  // the next event, as a session asks once it has written the last one
        const std::lock_guard<std::mutex> lock(mutex);
        return !events.empty() &&
               (store::is_terminal(events.back().state) || events.back().message.rfind("handed back", 0) == 0);
      },
      60))
      << "the job neither ended nor went back to the queue";
  queue.shutdown();
  workers.join();

  EXPECT_GE(records.refused.load(), 1);
  // Not failed: still queued, with no error, for the next claim (in a farm, any node's) to run.
  const store::JobRecord after = *db.get(inserted.id);
  EXPECT_EQ(after.state, store::JobState::queued);
  EXPECT_TRUE(after.error.empty()) << after.error;
  const std::lock_guard<std::mutex> lock(mutex);
  EXPECT_EQ(events.back().state, store::JobState::queued) << events.back().message;
  EXPECT_EQ(events.back().message, "handed back: cannot connect to Redis at unix:/nowhere");
}

}  // namespace
}  // namespace kiln::daemon
