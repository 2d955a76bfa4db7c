// The farm's retention (daemon/cluster/farm_retention.h) against a real redis-server and a store folder the nodes
// share: eviction decided once for the farm, least recently used first, never a pinned or recently used blob, the
// results that lose a blob out of the cache, a submit racing an eviction refused, and old job records expired.
#include "daemon/cluster/farm_retention.h"

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <thread>

#include "daemon/cluster/farm_job_hash.h"
#include "daemon/cluster/farm_jobs.h"
#include "daemon/cluster/farm_queue.h"
#include "daemon/cluster/farm_scripts.h"
#include "tests/cluster/redis_server.h"

namespace kiln::cluster {
namespace {

using store::JobState;
using test::RedisServer;

class FarmRetentionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (RedisServer::binary().empty()) GTEST_SKIP() << RedisServer::kSkipMessage;
    server_ = std::make_unique<RedisServer>();
    redis_ = std::make_unique<RedisClient>(server_->options());
    store_dir_ = server_->dir() / "store";
    blobs_ = std::make_unique<store::BlobStore>(store_dir_);
  }
  FarmRetention node(const std::string& name, uint64_t limit, double grace_seconds = 0) {
    FarmRetentionOptions o;
    o.node = name;
    o.store_limit_bytes = limit;
    o.eviction_grace_seconds = grace_seconds;
    o.job_retention_seconds = 0;
    return FarmRetention(o, *blobs_);
  }
  // A blob of `size` bytes, distinct per `seed`.
  std::string blob(char seed, size_t size = 1000) { return blobs_->put(std::string(size, seed)).digest; }
  // A job with these inputs that ran on a worker and succeeded with these outputs.
  std::string baked(const std::string& name, std::vector<std::string> inputs, std::vector<std::string> outputs) {
    const std::string id = queued(name, std::move(inputs));
    const auto claim = worker_.claim(*redis_, 0);
    EXPECT_TRUE(claim && claim->job.id == id);
    worker_.commit_success(*redis_, *claim, "result of " + name, outputs);
    return id;
  }
  std::string queued(const std::string& name, std::vector<std::string> inputs) {
    store::NewJob j;
    j.name = name;
    j.type = "material";
    j.spec = "spec of " + name;
    j.spec_key = "key of " + name;
    j.input_digests = std::move(inputs);
    return jobs_.insert(*redis_, j, 0).job.id;
  }
  // The blob's last use, as the farm recorded it, `seconds_ago` before now.
  void last_used(const std::string& digest, double seconds_ago) {
    redis_->command({"ZADD", "kiln:blob_used", encode_time(store::unix_now() - seconds_ago), digest});
  }
  bool stored(const std::string& digest, size_t size = 1000) { return blobs_->contains({digest, size}); }

  std::unique_ptr<RedisServer> server_;
  std::unique_ptr<RedisClient> redis_;
  std::filesystem::path store_dir_;
  std::unique_ptr<store::BlobStore> blobs_;
  FarmJobs jobs_;
  FarmQueue worker_{FarmQueueOptions{"kiln:", "worker-node", std::chrono::minutes(10), 3}};
};

TEST_F(FarmRetentionTest, EvictsLeastRecentlyUsedFirstAndNeverWhatAQueuedJobReads) {
  const std::string input = blob('i');
  const std::string older = blob('o');
  const std::string newer = blob('n');
  const std::string first = baked("first", {}, {older});
  const std::string second = baked("second", {}, {newer});
  queued("waiting", {input});
  last_used(input, 9000);  // the oldest of all, but pinned by the queued job
  last_used(older, 7200);
  last_used(newer, 3600);

  // 3,000 bytes, limit 2,000: one blob goes, the least recently used that no job waits for.
  FarmRetention a = node("a", 2000);
  FarmRetentionReport r = a.run(*redis_);
  EXPECT_TRUE(r.ran);
  ASSERT_EQ(r.blobs.removed.size(), 1u);
  EXPECT_EQ(r.blobs.removed[0].digest, older);
  EXPECT_EQ(r.results_evicted, 1u);
  EXPECT_FALSE(stored(older));
  EXPECT_TRUE(stored(input));
  EXPECT_TRUE(stored(newer));
  // The result that lost its output leaves the cache on every node: a later submit bakes again.
  EXPECT_TRUE(jobs_.get(*redis_, first)->evicted);
  EXPECT_FALSE(jobs_.find_succeeded_by_spec_key(*redis_, "key of first"));
  EXPECT_TRUE(jobs_.find_succeeded_by_spec_key(*redis_, "key of second"));
  EXPECT_EQ(redis_->command({"EXISTS", "kiln:out:" + older}).as_integer(), 0);

  // A limit of 1 byte: everything unpinned goes, and the pass says the limit cannot be met.
  r = node("b", 1).run(*redis_);
  EXPECT_EQ(r.blobs.removed.size(), 1u);
  EXPECT_TRUE(r.blobs.limit_unreachable);
  EXPECT_TRUE(stored(input));
  EXPECT_FALSE(stored(newer));
  EXPECT_FALSE(jobs_.find_succeeded_by_spec_key(*redis_, "key of second"));
}

TEST_F(FarmRetentionTest, NeverEvictsABlobUsedWithinTheGrace) {
  const std::string old_output = blob('o');
  const std::string fresh_output = blob('f');
  const std::string uploaded = blob('u');  // never submitted: its file's time is its last use
  baked("old", {}, {old_output});
  const std::string fresh = baked("fresh", {}, {fresh_output});
  last_used(old_output, 7200);
  last_used(fresh_output, 7200);
  // A client read the fresh job's result ten minutes ago: its outputs are about to be fetched.
  ASSERT_TRUE(jobs_.touch(*redis_, fresh, store::unix_now() - 600));

  const FarmRetentionReport r = node("a", 1, /*grace_seconds=*/3600).run(*redis_);
  ASSERT_EQ(r.blobs.removed.size(), 1u);
  EXPECT_EQ(r.blobs.removed[0].digest, old_output);
  EXPECT_TRUE(stored(fresh_output));
  EXPECT_TRUE(stored(uploaded));
  EXPECT_TRUE(r.blobs.limit_unreachable);
}

TEST_F(FarmRetentionTest, OneNodeEvictsAtATime) {
  const std::string output = blob('o');
  baked("job", {}, {output});
  last_used(output, 7200);
  // Node b holds the farm's retention lock: node a's pass does nothing.
  redis_->command({"SET", "kiln:retention", "b/1234", "PX", "60000"});
  FarmRetention a = node("a", 1);
  FarmRetentionReport r = a.run(*redis_);
  EXPECT_FALSE(r.ran);
  EXPECT_TRUE(stored(output));
  // A removal is confirmed against the lock: a node whose lock passed to another removes nothing more.
  const RedisReply verdict = redis_->eval(scripts::evict_blob(), {},
                                          {"kiln:", "a/stale", encode_time(store::unix_now()),
                                           encode_time(store::unix_now()), "60000", output});
  EXPECT_EQ(verdict.as_array().at(0).as_integer(), -1);
  // Once b is done (its lock gone), a's pass runs, and leaves no lock behind.
  redis_->command({"DEL", "kiln:retention"});
  r = a.run(*redis_);
  EXPECT_TRUE(r.ran);
  EXPECT_FALSE(stored(output));
  EXPECT_TRUE(redis_->command({"GET", "kiln:retention"}).is_nil());
}

TEST_F(FarmRetentionTest, APinTakenAfterThePassLookedStillSavesTheBlob) {
  const std::string input = blob('i');
  last_used(input, 7200);
  // The pass's snapshot saw no pin; a submit on another node pins the blob before the removal is confirmed.
  redis_->command({"SET", "kiln:retention", "a/1", "PX", "60000"});
  queued("late submit", {input});
  const std::string cutoff = encode_time(store::unix_now());
  const RedisReply verdict = redis_->eval(scripts::evict_blob(), {},
                                          {"kiln:", "a/1", encode_time(store::unix_now()), cutoff, "60000", input});
  EXPECT_EQ(verdict.as_array().at(0).as_integer(), 0);
}

TEST_F(FarmRetentionTest, ASubmitThatSawAnEvictedInputIsRefusedUntilItIsUploadedAgain) {
  const std::string input = blob('i');
  last_used(input, 7200);
  FarmRetention a = node("a", 1);
  ASSERT_EQ(a.run(*redis_).blobs.removed.size(), 1u);
  // The service checked the file before the eviction and inserts after it: refused, saying what to do.
  try {
    queued("raced", {input});
    ADD_FAILURE() << "a job was queued whose input was just evicted";
  } catch (const store::StoreError& e) {
    EXPECT_EQ(e.code(), store::StoreErrc::not_found);
    EXPECT_NE(std::string(e.what()).find(input), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("upload it again"), std::string::npos) << e.what();
  }
  // Uploaded again: the submit goes through, and the new copy is recent, so the next pass keeps it.
  blob('i');
  a.stored(*redis_, input);
  EXPECT_FALSE(queued("after the upload", {input}).empty());
  EXPECT_TRUE(a.run(*redis_).blobs.removed.empty());
}

TEST_F(FarmRetentionTest, ACacheHitOnAResultEvictedMeanwhileBakesInstead) {
  const std::string output = blob('o');
  const std::string source = baked("source", {}, {output});
  last_used(output, 7200);
  // The service looked the result up in the cache, then the eviction removed its output.
  ASSERT_EQ(node("a", 1).run(*redis_).results_evicted, 1u);
  store::NewJob again;
  again.name = "again";
  again.type = "material";
  again.spec = "spec of source";
  again.spec_key = "key of source";
  again.cached = store::CachedResult{source, "cached result", {output}};
  const store::InsertOutcome out = jobs_.insert(*redis_, again, 0);
  EXPECT_EQ(out.job.state, JobState::queued);
  EXPECT_FALSE(out.job.cache_source);
}

}  // namespace
}  // namespace kiln::cluster

namespace kiln::cluster {
namespace {

// Redis's own count of the bytes it holds (INFO memory, used_memory).
long long used_memory(RedisClient& redis) {
  const std::string info = redis.command({"INFO", "memory"}).as_string();
  const size_t at = info.find("used_memory:");
  return std::stoll(info.substr(at + 12));
}

long long keys_matching(RedisClient& redis, const std::string& pattern) {
  return static_cast<long long>(redis.command({"KEYS", pattern}).as_array().size());
}

TEST_F(FarmRetentionTest, ExpiresFinishedJobsUnusedPastTheRetentionAndNothingElse) {
  const std::string output = blob('o');
  store::NewJob keyed;
  keyed.name = "keyed";
  keyed.type = "material";
  keyed.spec = "spec of keyed";
  keyed.spec_key = "key of keyed";
  keyed.idempotency_key = "build-7/keyed";
  const std::string old_done = jobs_.insert(*redis_, keyed, 0).job.id;
  worker_.commit_success(*redis_, *worker_.claim(*redis_, 0), "result", {output});
  const std::string old_failed = queued("failed", {});
  worker_.commit_failure(*redis_, *worker_.claim(*redis_, 0), "job.material: broken");
  const std::string old_cancelled = queued("cancelled", {});
  jobs_.cancel(*redis_, old_cancelled);
  const std::string reread = baked("read again later", {}, {});
  const double cutoff = store::unix_now();
  ASSERT_TRUE(jobs_.touch(*redis_, reread, cutoff + 1));  // its result was read after the cutoff
  const std::string running = queued("running", {});
  ASSERT_TRUE(worker_.claim(*redis_, 0));
  const std::string waiting = queued("waiting", {});

  FarmRetention a = node("a", 0);
  EXPECT_EQ(a.expire_jobs(*redis_, cutoff), 3u);
  for (const std::string& id : {old_done, old_failed, old_cancelled}) {
    EXPECT_FALSE(jobs_.get(*redis_, id)) << id;
    EXPECT_EQ(redis_->command({"ZSCORE", "kiln:jobs", id}).is_nil(), true) << id;
  }
  for (const std::string& id : {reread, running, waiting}) EXPECT_TRUE(jobs_.get(*redis_, id)) << id;
  EXPECT_EQ(jobs_.list(*redis_, 100).size(), 3u);
  EXPECT_EQ(jobs_.list(*redis_, 100, JobState::failed).size(), 0u);
  // Its cache entry, idempotency key and place among its output's results went with it: the same submit bakes again.
  EXPECT_FALSE(jobs_.find_succeeded_by_spec_key(*redis_, "key of keyed"));
  EXPECT_TRUE(jobs_.insert(*redis_, keyed, 0).created);
  EXPECT_EQ(redis_->command({"EXISTS", "kiln:out:" + output}).as_integer(), 0);
  EXPECT_EQ(a.expire_jobs(*redis_, cutoff), 0u) << "expired once";
}

// Redis's memory per job record, and after their expiry (docs/SCALING.md quotes the figures this prints).
TEST_F(FarmRetentionTest, ExpiryGivesBackTheMemoryOfTheRecords) {
  constexpr int kJobs = 2000;
  FarmRetention a = node("a", 0);
  // One job first, expired at once: its scripts are loaded, its stream and consumer group made, before `before`.
  baked("warm-up", {}, {});
  a.expire_jobs(*redis_, store::unix_now() + 1);
  const long long before = used_memory(*redis_);
  for (int i = 0; i < kJobs; ++i) {
    store::NewJob j;
    j.name = "job " + std::to_string(i);
    j.type = "material";
    j.spec = std::string(300, 's');  // about a small material job's serialized spec
    j.spec_key = "key " + std::to_string(i);
    j.idempotency_key = "build/" + std::to_string(i);
    j.input_digests = {std::string(64, 'a')};
    jobs_.insert(*redis_, j, 0);
    const auto claim = worker_.claim(*redis_, 0);
    ASSERT_TRUE(claim);
    // A result of about a material job's (outputs and a report), with one output of its own.
    char digest[65];
    std::snprintf(digest, sizeof digest, "%064x", i);
    worker_.commit_success(*redis_, *claim, std::string(1200, 'r'), {digest});
  }
  const long long with_records = used_memory(*redis_);
  const double per_record = double(with_records - before) / kJobs;
  ASSERT_EQ(a.expire_jobs(*redis_, store::unix_now() + 1), size_t(kJobs));
  const long long blob_uses = redis_->command({"MEMORY", "USAGE", "kiln:blob_used"}).as_integer();
  // Redis shrinks the hash tables of its keyspace and sorted sets, and trims a client's query buffer, in its own
  // time (its cron and later operations): up to some hundreds of kB right after the deletes, depending on timing.
  // What is measured is what stays once that is done, waited for up to 20 s (it takes well under one on an idle
  // machine).
  const auto settled = [&](long long used) { return double(used - before - blob_uses) / kJobs < per_record / 20; };
  long long after = used_memory(*redis_);
  for (int wait = 0; wait < 200 && !settled(after); ++wait) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    after = used_memory(*redis_);
  }
  std::printf("Redis used_memory: %lld bytes before, %lld with %d finished job records (%.0f bytes a record), "
              "%lld after their expiry (%.0f bytes a record left, of which %.0f the outputs' last uses)\n",
              before, with_records, kJobs, per_record, after, double(after - before) / kJobs,
              double(blob_uses) / kJobs);
  RecordProperty("bytes_per_record", static_cast<int>(per_record));
  EXPECT_EQ(keys_matching(*redis_, "kiln:job:*"), 0);
  EXPECT_EQ(keys_matching(*redis_, "kiln:idem:*"), 0);
  EXPECT_EQ(keys_matching(*redis_, "kiln:cache:*"), 0);
  EXPECT_EQ(keys_matching(*redis_, "kiln:out:*"), 0);
  EXPECT_EQ(redis_->command({"ZCARD", "kiln:jobs"}).as_integer(), 0);
  EXPECT_EQ(redis_->command({"ZCARD", "kiln:finished"}).as_integer(), 0);
  // What stays is the outputs' last uses (kiln:blob_used, kept until retention evicts the blobs) and less than a
  // twentieth of a record's bytes.
  EXPECT_LT(double(after - before - blob_uses) / kJobs, per_record / 20);
}

}  // namespace
}  // namespace kiln::cluster
