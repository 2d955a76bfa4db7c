// Nodes of a farm in one process (daemon/cluster/farm.h), each with its own connections and threads, against a
// real redis-server: a job submitted through one runs on another, a cancel and a watch cross nodes, a lost lease
// stops a run, and a node rides out Redis going away.
#include "daemon/cluster/farm.h"

#include <gtest/gtest.h>

#include <condition_variable>
#include <future>
#include <memory>
#include <mutex>
#include <set>
#include <thread>

#include "daemon/cluster/farm_jobs.h"
#include "tests/cluster/redis_server.h"
#include "tests/support/eventually.h"

namespace kiln::cluster {
namespace {

using store::JobState;
using test::RedisServer;

using test::eventually;

store::NewJob job(const std::string& name) {
  store::NewJob j;
  j.name = name;
  j.type = "material";
  j.spec = "spec of " + name;
  j.spec_key = "key of " + name;
  return j;
}

class FarmNodeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (RedisServer::binary().empty()) GTEST_SKIP() << RedisServer::kSkipMessage;
    server_ = std::make_unique<RedisServer>();
  }
  Farm node(const std::string& name, std::chrono::milliseconds lease = std::chrono::seconds(30)) {
    FarmConfig c;
    c.url = server_->url();
    c.node = name;
    c.lease = lease;
    return join_farm(c);
  }
  std::unique_ptr<RedisServer> server_;
};

TEST_F(FarmNodeTest, AJobSubmittedToOneNodeRunsOnAnotherAndEveryNodeSeesItsResult) {
  Farm a = node("a"), b = node("b");
  const store::JobRecord submitted = a.records->insert(job("plate")).job;
  EXPECT_EQ(b.queue->size(), 1u);  // the farm's queue, seen from any node
  const auto popped = b.queue->pop();
  ASSERT_TRUE(popped);
  EXPECT_EQ(popped->id, submitted.id);
  EXPECT_EQ(b.queue->running(), 1u);
  EXPECT_EQ(a.queue->running(), 0u);
  EXPECT_EQ(b.records->mark_running(popped->id).state, JobState::running);
  EXPECT_THROW(a.records->mark_running(popped->id), store::StoreError) << "a runs nothing";
  b.records->mark_succeeded(popped->id, "the result", {std::string(64, 'c')});
  b.queue->finish(popped->id, store::Progress{JobState::succeeded, 1, {}, 0, {}, "done"});
  const auto seen = a.records->get(submitted.id);
  EXPECT_EQ(seen->state, JobState::succeeded);
  EXPECT_EQ(seen->result, "the result");
  EXPECT_EQ(a.records->find_succeeded_by_spec_key("key of plate")->id, submitted.id);
  EXPECT_EQ(a.records->counts().succeeded, 1u);
  EXPECT_EQ(b.queue->running(), 0u);
}

TEST_F(FarmNodeTest, ACancelThroughOneNodeReachesTheBakeOnAnother) {
  Farm a = node("a"), b = node("b");
  const std::string id = a.records->insert(job("long bake")).job.id;
  const auto popped = b.queue->pop();
  ASSERT_TRUE(popped);
  EXPECT_EQ(a.queue->cancel(id), store::CancelOutcome::signalled);
  EXPECT_TRUE(eventually([&] { return popped->cancel->load(); })) << "b's bake never saw the cancel";
  EXPECT_EQ(b.records->mark_cancelled(id).state, JobState::cancelled);
  EXPECT_EQ(a.records->get(id)->state, JobState::cancelled);
  // A queued job's cancel is recorded at once, whichever node is asked.
  const std::string queued = b.records->insert(job("never runs")).job.id;
  EXPECT_EQ(a.queue->cancel(queued), store::CancelOutcome::removed_from_queue);
  EXPECT_EQ(a.records->mark_cancelled(queued).state, JobState::cancelled);
}

TEST_F(FarmNodeTest, AWatchOnOneNodeFollowsTheBakeOnAnother) {
  Farm a = node("a"), b = node("b");
  const std::string id = a.records->insert(job("watched")).job.id;
  const auto popped = b.queue->pop();
  ASSERT_TRUE(popped);
  std::mutex mu;
  std::vector<store::Progress> seen;
  store::Subscription watch = a.queue->subscribe(id, [&](const store::Progress& p) {
    std::lock_guard lock(mu);
    seen.push_back(p);
  });
  ASSERT_TRUE(watch);
  auto last = [&] {
    watch.ready();  // as a session does once it wrote the previous event (it may deliver one at once)
    std::lock_guard lock(mu);
    return seen.empty() ? store::Progress{} : seen.back();
  };
  EXPECT_TRUE(eventually([&] { return last().state == JobState::running; }));
  b.queue->publish(id, store::Progress{JobState::running, 0.5, {}, 100, {}, "half"});
  EXPECT_TRUE(eventually([&] { return last().fraction == 0.5; })) << "a's watcher never saw b's progress";
  b.records->mark_succeeded(id, "result", {});
  b.queue->finish(id, store::Progress{JobState::succeeded, 1, {}, 100, {}, "done"});
  EXPECT_TRUE(eventually([&] { return last().state == JobState::succeeded; })) << "no final event on a";
}

TEST_F(FarmNodeTest, AStoppingNodeHandsItsJobsBackToTheFarm) {
  Farm a = node("a"), b = node("b");
  const std::string interrupted = a.records->insert(job("interrupted")).job.id;
  const std::string waiting = a.records->insert(job("waiting for memory")).job.id;
  const auto first = a.queue->pop();
  const auto second = a.queue->pop();
  ASSERT_TRUE(first && second);
  // A bake the shutdown interrupted (the workers' record_cancelled), and a job the shutdown caught before it ran
  // (wait_for_memory): both are queued in the farm again at once, without waiting for a lease.
  EXPECT_EQ(a.records->mark_queued(interrupted).state, JobState::queued);
  a.queue->finish(interrupted, store::Progress{JobState::queued, 0, {}, 0, {}, "re-queued by a daemon shutdown"});
  a.queue->finish(waiting, store::Progress{JobState::queued, 0, {}, 0, {}, "queued until kilnd starts again"});
  EXPECT_EQ(b.records->get(waiting)->state, JobState::queued);
  std::set<std::string> taken;
  for (int i = 0; i < 2; ++i) taken.insert(b.queue->pop()->id);
  EXPECT_EQ(taken, (std::set<std::string>{interrupted, waiting}));
  EXPECT_EQ(a.queue->running(), 0u);
}

TEST_F(FarmNodeTest, ANodeThatLostItsLeaseStopsAndTheOtherRunCounts) {
  Farm slow = node("slow"), fast = node("fast", std::chrono::milliseconds(0));
  const std::string id = slow.records->insert(job("contested")).job.id;
  const auto first = slow.queue->pop();
  ASSERT_TRUE(first);
  // `fast` treats every lease as run out: what any node does once `slow` has been silent past the lease.
  const auto second = fast.queue->pop();
  ASSERT_TRUE(second);
  EXPECT_EQ(second->id, id);
  EXPECT_TRUE(eventually([&] { return first->cancel->load(); })) << "slow kept baking a job it no longer held";
  slow.records->mark_cancelled(id);  // what its worker does when the bake stops: nothing reaches the farm
  EXPECT_EQ(fast.records->get(id)->state, JobState::running);
  fast.records->mark_succeeded(id, "fast's result", {});
  EXPECT_EQ(slow.records->get(id)->result, "fast's result");
}

TEST_F(FarmNodeTest, ANodeWaitsOutRedisAndResumesWhenItReturns) {
  Farm a = node("a"), b = node("b");
  server_->stop();
  try {
    a.records->insert(job("while away"));
    ADD_FAILURE() << "a submit succeeded without Redis";
  } catch (const store::StoreError& e) {
    EXPECT_EQ(e.code(), store::StoreErrc::unavailable);
    EXPECT_NE(std::string(e.what()).find(server_->url()), std::string::npos) << e.what();
  }
  // b's worker keeps trying to claim while Redis is away, and gets the job submitted once it is back.
  auto worker = std::async(std::launch::async, [&] { return b.queue->pop(); });
  server_->start();
  std::string id;
  ASSERT_TRUE(eventually([&] {
    try {
      id = a.records->insert(job("after")).job.id;
      return true;
    } catch (const store::StoreError&) {
      return false;  // the first command after the restart meets the broken connection
    }
  }));
  const auto popped = worker.get();
  ASSERT_TRUE(popped);
  EXPECT_EQ(popped->id, id);
}

}  // namespace
}  // namespace kiln::cluster
