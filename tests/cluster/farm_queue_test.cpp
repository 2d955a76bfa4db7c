// The farm's queue and job records (docs/SCALING.md) against a real redis-server: order, claims, leases, reclaim,
// commit-once, cancel, hand-back, the result cache, and a Redis crash.
#include "daemon/cluster/farm_queue.h"

#include <gtest/gtest.h>

#include <memory>
#include <set>

#include "daemon/cluster/farm_jobs.h"
#include "tests/cluster/redis_server.h"

namespace kiln::cluster {
namespace {

using store::JobState;
using test::RedisServer;

const std::string kDigestA(64, 'a');
const std::string kDigestB(64, 'b');

store::NewJob job(const std::string& name, int priority, const std::string& spec_key = "") {
  store::NewJob j;
  j.name = name;
  j.type = "material";
  j.spec = "spec of " + name;
  j.spec_key = spec_key.empty() ? "key-" + name : spec_key;
  j.priority = priority;
  j.input_digests = {kDigestA};
  return j;
}

class FarmQueueTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (RedisServer::binary().empty()) GTEST_SKIP() << RedisServer::kSkipMessage;
    // appendfsync always: what deploy/redis ships, and what the crash test below relies on.
    server_ = std::make_unique<RedisServer>(std::vector<std::string>{"--appendfsync", "always"});
    redis_ = std::make_unique<RedisClient>(server_->options());
  }
  // A node's queue. A lease of 0 ms makes every running job's lease count as expired at once: how a claim after a
  // node died behaves, without waiting for a real lease to run out.
  FarmQueue node(const std::string& name, std::chrono::milliseconds lease = std::chrono::minutes(10),
                 int max_crash_restarts = 3) {
    FarmQueueOptions o;
    o.node = name;
    o.lease = lease;
    o.max_crash_restarts = max_crash_restarts;
    return FarmQueue(o);
  }
  store::JobRecord insert(const store::NewJob& j) { return jobs_.insert(*redis_, j, 0).job; }
  JobState state_of(const std::string& id) { return jobs_.get(*redis_, id)->state; }

  std::unique_ptr<RedisServer> server_;
  std::unique_ptr<RedisClient> redis_;
  FarmJobs jobs_;
};

TEST_F(FarmQueueTest, InsertRecordsTheJobForEveryNode) {
  store::NewJob j = job("plate", 7);
  j.idempotency_key = "build-42/plate";
  const store::InsertOutcome first = jobs_.insert(*redis_, j, 0);
  EXPECT_TRUE(first.created);
  EXPECT_EQ(first.job.id.size(), 32u);
  EXPECT_EQ(first.job.state, JobState::queued);
  EXPECT_EQ(first.job.name, "plate");
  EXPECT_EQ(first.job.spec, "spec of plate");
  EXPECT_EQ(first.job.priority, 7);
  EXPECT_EQ(first.job.input_digests, std::vector<std::string>{kDigestA});
  // Another node's connection sees the same record.
  RedisClient other(server_->options());
  const auto seen = jobs_.get(other, first.job.id);
  ASSERT_TRUE(seen);
  EXPECT_EQ(seen->seq, first.job.seq);
  EXPECT_EQ(seen->idempotency_key, "build-42/plate");
  EXPECT_FALSE(jobs_.get(other, std::string(32, '0')));
  // The same key and spec: the first job again. Another spec: refused, naming the first job.
  const store::InsertOutcome again = jobs_.insert(other, j, 0);
  EXPECT_FALSE(again.created);
  EXPECT_EQ(again.job.id, first.job.id);
  j.spec_key = "another spec";
  try {
    jobs_.insert(other, j, 0);
    ADD_FAILURE() << "a reused idempotency key was accepted for another spec";
  } catch (const store::StoreError& e) {
    EXPECT_EQ(e.code(), store::StoreErrc::already_exists);
    EXPECT_NE(std::string(e.what()).find(first.job.id), std::string::npos) << e.what();
  }
  EXPECT_EQ(jobs_.find_by_idempotency_key(other, "build-42/plate")->id, first.job.id);
  EXPECT_EQ(jobs_.counts(other).jobs.queued, 1u);
}

TEST_F(FarmQueueTest, RefusesWhatTheSingleNodeStoreRefuses) {
  store::NewJob bad = job("x", 0);
  bad.type.clear();
  EXPECT_THROW(jobs_.insert(*redis_, bad, 0), store::StoreError);
  bad = job("x", 0);
  bad.input_digests = {"not a digest"};
  EXPECT_THROW(jobs_.insert(*redis_, bad, 0), store::StoreError);
  EXPECT_THROW(jobs_.get(*redis_, std::string(300, 'x')), store::StoreError);
  // The queue's limit counts the whole farm's queued jobs.
  insert(job("one", 0));
  try {
    jobs_.insert(*redis_, job("two", 0), 1);
    ADD_FAILURE() << "a full queue took another job";
  } catch (const store::StoreError& e) {
    EXPECT_EQ(e.code(), store::StoreErrc::resource_exhausted);
  }
}

TEST_F(FarmQueueTest, ClaimsHigherPriorityFirstThenArrival) {
  // The order single-node kilnd's JobQueue promises: priority descending, then seq ascending.
  const std::vector<std::pair<std::string, int>> submitted = {{"a", 0}, {"b", 5}, {"c", -3}, {"d", 5}, {"e", 0}};
  for (const auto& [name, priority] : submitted) insert(job(name, priority));
  FarmQueue q = node("n1");
  std::vector<std::string> order;
  while (auto c = q.claim(*redis_, 0)) {
    EXPECT_EQ(c->job.state, JobState::running);
    EXPECT_EQ(c->job.attempts, 1);
    order.push_back(c->job.name);
  }
  EXPECT_EQ(order, (std::vector<std::string>{"b", "d", "a", "e", "c"}));
  EXPECT_EQ(jobs_.counts(*redis_).jobs.running, 5u);
  EXPECT_EQ(jobs_.counts(*redis_).jobs.queued, 0u);
}

TEST_F(FarmQueueTest, NoTwoWorkersClaimTheSameJob) {
  std::set<std::string> ids;
  for (int i = 0; i < 40; ++i) ids.insert(insert(job("j" + std::to_string(i), i % 3)).id);
  FarmQueue n1 = node("n1"), n2 = node("n2");
  RedisClient other(server_->options());
  std::multiset<std::string> claimed;
  for (bool more = true; more;) {
    auto a = n1.claim(*redis_, 0);
    auto b = n2.claim(other, 1);
    if (a) claimed.insert(a->job.id);
    if (b) claimed.insert(b->job.id);
    more = a || b;
  }
  EXPECT_EQ(claimed.size(), ids.size());
  EXPECT_EQ(std::set<std::string>(claimed.begin(), claimed.end()), ids);
}

TEST_F(FarmQueueTest, ALiveLeaseKeepsTheJobAndAnExpiredOneIsReclaimed) {
  const std::string id = insert(job("plate", 0)).id;
  FarmQueue n1 = node("n1");
  const auto first = n1.claim(*redis_, 0);
  ASSERT_TRUE(first);
  EXPECT_FALSE(node("n2").claim(*redis_, 0)) << "a job under a live lease was claimed again";
  EXPECT_TRUE(n1.renew(*redis_, *first).held);
  // n1 stops renewing (it died): with its lease run out, n2's claim takes the job and runs it again.
  FarmQueue n2 = node("n2", std::chrono::milliseconds(0));
  const auto second = n2.claim(*redis_, 0);
  ASSERT_TRUE(second);
  EXPECT_EQ(second->job.id, id);
  EXPECT_EQ(second->job.attempts, 2);
  EXPECT_EQ(second->entry, first->entry);
  EXPECT_FALSE(n1.renew(*redis_, *first).held) << "n1 must learn it lost the lease";
  EXPECT_TRUE(n2.renew(*redis_, *second).held);
  EXPECT_EQ(jobs_.counts(*redis_).jobs.running, 1u);
}

TEST_F(FarmQueueTest, TheFirstResultWinsAndALateOneIsCountedAndDiscarded) {
  const std::string id = insert(job("plate", 0, "cache-key-1")).id;
  FarmQueue n1 = node("n1");
  const auto first = n1.claim(*redis_, 0);
  const auto second = node("n2", std::chrono::milliseconds(0)).claim(*redis_, 0);
  ASSERT_TRUE(first && second);
  // The node that lost its lease still finishes first: its result is the job's.
  EXPECT_EQ(n1.commit_success(*redis_, *first, "result from n1", {kDigestB}), CommitOutcome::committed);
  EXPECT_EQ(node("n2").commit_success(*redis_, *second, "result from n2", {kDigestB}), CommitOutcome::duplicate);
  const auto record = jobs_.get(*redis_, id);
  EXPECT_EQ(record->state, JobState::succeeded);
  EXPECT_EQ(record->result, "result from n1");
  EXPECT_EQ(record->output_digests, std::vector<std::string>{kDigestB});
  const FarmCounts c = jobs_.counts(*redis_);
  EXPECT_EQ(c.jobs.succeeded, 1u);
  EXPECT_EQ(c.jobs.running, 0u);
  EXPECT_EQ(c.duplicates, 1u);
  // The result cache answers from any node; nothing is left to claim.
  RedisClient other(server_->options());
  EXPECT_EQ(jobs_.find_succeeded_by_spec_key(other, "cache-key-1")->id, id);
  EXPECT_FALSE(node("n3", std::chrono::milliseconds(0)).claim(other, 0));
  EXPECT_EQ(jobs_.latest(other, id)->state, JobState::succeeded);
}

TEST_F(FarmQueueTest, ACacheHitIsRecordedSucceededAndNeverQueued) {
  const std::string source = insert(job("plate", 0, "cache-key-2")).id;
  FarmQueue n1 = node("n1");
  n1.commit_success(*redis_, *n1.claim(*redis_, 0), "the result", {kDigestB});
  store::NewJob again = job("plate again", 0, "cache-key-2");
  again.cached = store::CachedResult{source, "the result, marked a cache hit", {kDigestB}};
  const store::InsertOutcome hit = jobs_.insert(*redis_, again, 0);
  EXPECT_EQ(hit.job.state, JobState::succeeded);
  EXPECT_EQ(hit.job.cache_source, source);
  EXPECT_EQ(hit.job.result, "the result, marked a cache hit");
  EXPECT_FALSE(n1.claim(*redis_, 0));
  EXPECT_EQ(jobs_.counts(*redis_).jobs.cache_hits, 1u);
}

TEST_F(FarmQueueTest, AResultWhoseBlobIsGoneLeavesTheCache) {
  const std::string id = insert(job("plate", 0, "cache-key-3")).id;
  FarmQueue n1 = node("n1");
  n1.commit_success(*redis_, *n1.claim(*redis_, 0), "the result", {kDigestB});
  EXPECT_EQ(jobs_.mark_results_evicted(*redis_, {kDigestA}), 0u) << "an input is no output";
  EXPECT_EQ(jobs_.mark_results_evicted(*redis_, {kDigestB}), 1u);
  EXPECT_FALSE(jobs_.find_succeeded_by_spec_key(*redis_, "cache-key-3"));
  EXPECT_TRUE(jobs_.get(*redis_, id)->evicted);
  EXPECT_EQ(jobs_.mark_results_evicted(*redis_, {kDigestB}), 0u) << "counted once";
}

TEST_F(FarmQueueTest, FailuresAreRecordedWithTheirReason) {
  const std::string id = insert(job("plate", 0)).id;
  FarmQueue n1 = node("n1");
  EXPECT_EQ(n1.commit_failure(*redis_, *n1.claim(*redis_, 0), "job.material.alpha: must be in (0, 1]"),
            CommitOutcome::committed);
  const auto r = jobs_.get(*redis_, id);
  EXPECT_EQ(r->state, JobState::failed);
  EXPECT_EQ(r->error, "job.material.alpha: must be in (0, 1]");
  EXPECT_EQ(jobs_.latest(*redis_, id)->message, "job.material.alpha: must be in (0, 1]");
}

TEST_F(FarmQueueTest, AJobThatKeepsLosingItsNodeIsFailedAtTheCrashLoopLimit) {
  const std::string id = insert(job("crasher", 0)).id;
  const auto zero = std::chrono::milliseconds(0);
  ASSERT_TRUE(node("n1", zero, 2).claim(*redis_, 0));  // attempt 1; n1 dies
  ASSERT_TRUE(node("n2", zero, 2).claim(*redis_, 0));  // attempt 2; n2 dies
  EXPECT_FALSE(node("n3", zero, 2).claim(*redis_, 0));
  const auto r = jobs_.get(*redis_, id);
  EXPECT_EQ(r->state, JobState::failed);
  EXPECT_NE(r->error.find("max_crash_restarts = 2"), std::string::npos) << r->error;
  EXPECT_EQ(jobs_.counts(*redis_).jobs.running, 0u);
}

TEST_F(FarmQueueTest, CancelRemovesAQueuedJobAndSignalsARunningOnesNode) {
  const std::string waiting = insert(job("waiting", 0)).id;
  EXPECT_EQ(jobs_.cancel(*redis_, waiting), store::CancelOutcome::removed_from_queue);
  EXPECT_EQ(state_of(waiting), JobState::cancelled);
  FarmQueue n1 = node("n1");
  EXPECT_FALSE(n1.claim(*redis_, 0)) << "a cancelled job was handed out";

  const std::string running = insert(job("running", 0)).id;
  const auto c = n1.claim(*redis_, 0);
  ASSERT_TRUE(c);
  RedisClient listener(server_->options());  // the running node's subscriber
  listener.send({"SUBSCRIBE", "kiln:cancel"});
  ASSERT_TRUE(listener.receive(std::chrono::seconds(30)));  // the subscription's confirmation
  RedisClient elsewhere(server_->options());
  EXPECT_EQ(jobs_.cancel(elsewhere, running), store::CancelOutcome::signalled);
  const auto message = listener.receive(std::chrono::seconds(30));
  ASSERT_TRUE(message);
  EXPECT_EQ(message->as_array().at(2).as_string(), running);
  // A node that missed the message learns it at its next renewal.
  const LeaseState lease = n1.renew(*redis_, *c);
  EXPECT_TRUE(lease.held);
  EXPECT_TRUE(lease.cancel_requested);
  EXPECT_EQ(n1.commit_cancelled(*redis_, *c), CommitOutcome::committed);
  EXPECT_EQ(state_of(running), JobState::cancelled);
  EXPECT_EQ(jobs_.cancel(*redis_, running), store::CancelOutcome::unknown);
  EXPECT_EQ(jobs_.counts(*redis_).jobs.cancelled, 2u);
  EXPECT_EQ(redis_->command({"HLEN", "kiln:pins"}).as_integer(), 0) << "finished jobs must unpin their inputs";
}

TEST_F(FarmQueueTest, AJobHandedBackRunsNextWithoutCountingAsACrash) {
  const std::string id = insert(job("plate", 0)).id;
  FarmQueue n1 = node("n1"), n2 = node("n2");
  const auto c = n1.claim(*redis_, 0);
  ASSERT_TRUE(c);
  EXPECT_FALSE(n2.requeue(*redis_, Claim{c->job, "n2/0", c->level, c->entry})) << "only the holder hands back";
  EXPECT_TRUE(n1.requeue(*redis_, *c));
  EXPECT_EQ(state_of(id), JobState::queued);
  const auto again = n2.claim(*redis_, 0);
  ASSERT_TRUE(again);
  EXPECT_EQ(again->job.id, id);
  EXPECT_EQ(again->job.attempts, 1);
  EXPECT_FALSE(n1.renew(*redis_, *c).held);
}

TEST_F(FarmQueueTest, ProgressReachesWatchersOnEveryNode) {
  const std::string id = insert(job("plate", 0)).id;
  RedisClient watcher(server_->options());
  watcher.send({"SUBSCRIBE", "kiln:ev:" + id});
  ASSERT_TRUE(watcher.receive(std::chrono::seconds(30)));
  FarmQueue n1 = node("n1");
  const auto c = n1.claim(*redis_, 0);
  const auto running = watcher.receive(std::chrono::seconds(30));  // the claim's event
  ASSERT_TRUE(running);
  store::Progress p;
  p.state = JobState::running;
  p.fraction = 0.25;
  p.eta_seconds = 3.5;
  p.samples = 4096;
  p.message = "tables\nline two";
  n1.publish(*redis_, id, p);
  const auto event = watcher.receive(std::chrono::seconds(30));
  ASSERT_TRUE(event);
  const auto latest = jobs_.latest(*redis_, id);
  ASSERT_TRUE(latest);
  EXPECT_EQ(latest->fraction, 0.25);
  EXPECT_EQ(latest->eta_seconds, 3.5);
  EXPECT_FALSE(latest->error_estimate);
  EXPECT_EQ(latest->samples, 4096u);
  EXPECT_EQ(latest->message, "tables\nline two");
  EXPECT_EQ(event->as_array().at(2).as_string(), redis_->command({"HGET", "kiln:job:" + id, "progress"}).str);
}

TEST_F(FarmQueueTest, ListsNewestFirstByStateWithPaging) {
  std::vector<std::string> ids;
  for (int i = 0; i < 5; ++i) ids.push_back(insert(job("j" + std::to_string(i), 0)).id);
  FarmQueue n1 = node("n1");
  n1.claim(*redis_, 0);  // j0 runs
  const auto all = jobs_.list(*redis_, 10);
  ASSERT_EQ(all.size(), 5u);
  EXPECT_EQ(all.front().id, ids[4]);
  EXPECT_TRUE(all.front().spec.empty()) << "list leaves payloads out";
  const auto page = jobs_.list(*redis_, 2, std::nullopt, all[1].seq);
  ASSERT_EQ(page.size(), 2u);
  EXPECT_EQ(page[0].id, ids[2]);
  EXPECT_EQ(page[1].id, ids[1]);
  const auto running = jobs_.list(*redis_, 10, JobState::running);
  ASSERT_EQ(running.size(), 1u);
  EXPECT_EQ(running[0].id, ids[0]);
  EXPECT_EQ(jobs_.list(*redis_, 10, JobState::queued).size(), 4u);
}

TEST_F(FarmQueueTest, NoAcceptedJobIsLostWhenRedisIsKilled) {
  std::set<std::string> ids;
  for (int i = 0; i < 6; ++i) ids.insert(insert(job("j" + std::to_string(i), i % 2)).id);
  FarmQueue n1 = node("n1");
  const auto running = n1.claim(*redis_, 0);
  ASSERT_TRUE(running);
  server_->kill();  // SIGKILL: no chance to flush anything beyond what each reply already waited for
  server_->start();
  RedisClient after(server_->options());
  EXPECT_EQ(jobs_.counts(after).jobs.queued, 5u);
  EXPECT_TRUE(n1.renew(after, *running).held) << "the lease survives the restart";
  std::set<std::string> claimed{running->job.id};
  while (auto c = node("n2").claim(after, 0)) claimed.insert(c->job.id);
  EXPECT_EQ(claimed, ids);
}

}  // namespace
}  // namespace kiln::cluster
