// A farm (docs/SCALING.md): redis-server and three kilnd nodes on loopback sharing one store folder. 200 small jobs
// go to random nodes while one node is killed with SIGKILL mid-bake, another restarted and Redis itself restarted;
// then every job has exactly one result, identical to a single node's bake of the same spec, and a resubmission
// through another node is a cache hit. Every wait is for an event (a state, a status), never a fixed sleep.
#include <gtest/gtest.h>

#include <atomic>
#include <future>
#include <map>
#include <memory>
#include <random>
#include <set>
#include <thread>

#include "tests/cluster/redis_server.h"
#include "tests/integration/service_client.h"
#include "tests/support/eventually.h"

namespace kiln::test {
namespace {

constexpr int kJobs = 200;

// A tiny material table (a Lambert albedo, 2 x 2 entries, no preview): tens of milliseconds each, so the test
// exercises the farm and not the baker. Job i's albedo differs from every other's, so no two share a cache key.
v1::JobSpec tiny_job(int i) {
  v1::JobSpec spec;
  spec.set_name("tiny " + std::to_string(i));
  v1::MaterialJob* m = spec.mutable_material();
  m->mutable_lambert()->mutable_albedo()->set_r(0.1 + 0.004 * i);
  m->mutable_lambert()->mutable_albedo()->set_g(0.5);
  m->mutable_lambert()->mutable_albedo()->set_b(0.5);
  m->set_table_mu(2);
  m->set_table_roughness(2);
  m->set_preview(false);
  spec.mutable_quality()->set_samples(16);
  return spec;
}

// Every output's digest but the report's (which holds timings), by name: what must match a single node's bake.
std::map<std::string, std::string> baked_bytes(const v1::JobResult& r) {
  std::map<std::string, std::string> out;
  for (const v1::Output& o : r.outputs()) {
    if (o.name() != "report.json") out[o.name()] = o.digest().sha256();
  }
  return out;
}

bool finished(v1::JobState s) {
  return s == v1::JOB_STATE_SUCCEEDED || s == v1::JOB_STATE_FAILED || s == v1::JOB_STATE_CANCELLED;
}

class FarmTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (RedisServer::binary().empty()) GTEST_SKIP() << RedisServer::kSkipMessage;
    redis_ = std::make_unique<RedisServer>(std::vector<std::string>{"--appendfsync", "always"});
    shared_ = redis_->dir() / "shared-store";
    // Node 1 kills itself with SIGKILL as it starts its fifth job: its claim held, its bake not done.
    for (int i = 0; i < 3; ++i) {
      nodes_.push_back(std::make_unique<Daemon>(
          flags(i), std::filesystem::path(),
          i == 1 ? std::vector<std::string>{"KILND_CRASH_AT=job.running:5"} : std::vector<std::string>{}));
    }
  }
  // A short lease, so the killed node's job runs elsewhere soon; the store every node mounts.
  std::vector<std::string> flags(int i) const {
    return {"--cluster",       redis_->url(),
            "--store",         shared_.string(),
            "--node-name",     "node" + std::to_string(i),
            "--cluster-lease", "2"};
  }
  void restart(int i) {
    const std::filesystem::path dir = nodes_[i]->dir();
    nodes_[i]->keep();
    EXPECT_EQ(nodes_[i]->terminate(), 0) << nodes_[i]->log();
    nodes_[i] = std::make_unique<Daemon>(flags(i), dir);
  }
  // Submits job i through node `n`, again while the node cannot reach Redis (the idempotency key makes a retry
  // after an unclear failure the same job).
  std::string submit(int i, int n) {
    std::string id;
    EXPECT_TRUE(eventually([&] {
      try {
        client::Client c = connect(*nodes_[n]);
        id = c.submit(tiny_job(i), 0, "farm-test-" + std::to_string(i)).job_id();
        return true;
      } catch (const client::ServerError& e) {
        if (e.code() != v1::Error::UNAVAILABLE) throw;
        return false;
      }
    })) << "node "
        << n << " never took job " << i;
    return id;
  }
  int running_on(int n) { return static_cast<int>(connect(*nodes_[n]).status().running()); }

  std::unique_ptr<RedisServer> redis_;
  std::filesystem::path shared_;
  std::vector<std::unique_ptr<Daemon>> nodes_;
};

TEST_F(FarmTest, TwoHundredJobsSurviveAKilledNodeARestartedNodeAndARestartedRedis) {
  std::mt19937 rng(22);
  std::vector<std::string> ids(kJobs);
  std::vector<int> through(kJobs);
  bool crashed = false;  // node 1, at its crash point
  auto node1_died = [&] { return crashed || (crashed = nodes_[1]->wait_for_crash(0)); };
  auto submit_to = [&](int i, std::vector<int> alive) {
    through[i] = alive[std::uniform_int_distribution<size_t>(0, alive.size() - 1)(rng)];
    if (through[i] == 1 && node1_died()) through[i] = 0;
    try {
      ids[i] = submit(i, through[i]);
    } catch (const std::exception&) {
      // Node 1 died under this submit: the same job (its idempotency key) through node 0.
      if (through[i] != 1) throw;
      through[i] = 0;
      ids[i] = submit(i, 0);
    }
  };
  int next = 0;
  // Jobs go to all three nodes until node 1 has died in its fifth job.
  while (next < 120 && !node1_died()) {
    for (int k = 0; k < 10; ++k) submit_to(next++, {0, 1, 2});
  }
  ASSERT_TRUE(eventually(node1_died)) << "node 1 never reached its crash point: " << nodes_[1]->log();
  for (int k = 0; k < 40; ++k) submit_to(next++, {0, 2});
  restart(2);  // a graceful stop hands its jobs back at once
  for (int k = 0; k < 20; ++k) submit_to(next++, {0, 2});
  redis_->stop();  // Redis restarts; the nodes wait it out
  redis_->start();
  while (next < kJobs) submit_to(next++, {0, 2});

  std::map<std::string, v1::JobResult> results;
  ASSERT_TRUE(eventually([&] {
    try {
      client::Client c = connect(*nodes_[0]);
      for (int i = 0; i < kJobs; ++i) {
        if (results.count(ids[i])) continue;
        v1::JobResult r = c.result(ids[i]);
        if (!finished(r.state())) return false;
        results[ids[i]] = r;
      }
      return true;
    } catch (const client::ServerError& e) {
      // Redis still loading its AOF after the restart: the node says UNAVAILABLE and to try again.
      if (e.code() != v1::Error::UNAVAILABLE) throw;
      return false;
    }
  })) << "not every job finished; node 0's log:\n"
      << nodes_[0]->log();

  // Exactly one job per submit (none lost, none twice), each succeeded, each a single node's bytes.
  EXPECT_EQ(std::set<std::string>(ids.begin(), ids.end()).size(), static_cast<size_t>(kJobs));
  Daemon alone;
  client::Client reference = connect(alone);
  for (int i = 0; i < kJobs; ++i) {
    const v1::JobResult& farm = results[ids[i]];
    ASSERT_EQ(farm.state(), v1::JOB_STATE_SUCCEEDED) << "job " << i << ": " << farm.error().message();
    const std::string single = reference.submit(tiny_job(i)).job_id();
    reference.watch(single);
    EXPECT_EQ(baked_bytes(farm), baked_bytes(reference.result(single))) << "job " << i;
  }
  cluster::RedisClient r(redis_->options());
  const auto count = [&](const char* field) {
    const auto v = r.command({"HGET", "kiln:counts", field});
    return v.is_nil() ? 0LL : std::stoll(v.str);
  };
  EXPECT_EQ(count("succeeded"), kJobs);
  EXPECT_EQ(count("queued"), 0);
  EXPECT_EQ(count("running"), 0);
  EXPECT_EQ(r.command({"HLEN", "kiln:pins"}).as_integer(), 0);
  // The job node 1 died in ran again elsewhere, and still has one result.
  int reruns = 0;
  for (const std::string& id : ids) reruns += std::stoi(r.command({"HGET", "kiln:job:" + id, "attempts"}).str) > 1;
  EXPECT_GE(reruns, 1);

  // Baked anywhere, a cache hit everywhere: job 0 again, through a node other than the one it was sent to.
  const int other = through[0] == 0 ? 2 : 0;
  client::Client again = connect(*nodes_[other]);
  const v1::SubmitReply hit = again.submit(tiny_job(0));
  EXPECT_TRUE(hit.cache_hit());
  const v1::JobResult cached = again.result(hit.job_id());
  EXPECT_EQ(baked_bytes(cached), baked_bytes(results[ids[0]]));
  // Its outputs come from the shared store through this node, whoever baked them.
  for (const v1::Output& o : cached.outputs()) EXPECT_EQ(again.fetch(o.digest()).size(), o.digest().size());
}

TEST_F(FarmTest, AWatchAndACancelThroughOtherNodesReachTheBakingNode) {
  // Minutes of baking unless cancelled (service_client.h): whichever node takes it, the others are not baking it.
  client::Client submitter = connect(*nodes_[0]);
  const std::string id = submitter.submit(ggx_job(0.3, 1 << 20, 64)).job_id();
  std::atomic<bool> running{false};
  auto watch = std::async(std::launch::async, [&] {
    client::Client watcher = connect(*nodes_[2]);
    return watcher.watch(id, [&](const v1::JobEvent& e) {
      if (e.state() == v1::JOB_STATE_RUNNING) running = true;
    });
  });
  ASSERT_TRUE(eventually([&] { return running.load(); })) << "node 2's watch never saw the job run";
  client::Client canceller = connect(*nodes_[1]);
  EXPECT_EQ(canceller.cancel(id), v1::JOB_STATE_CANCELLED);
  const v1::JobEvent last = watch.get();  // the watch on node 2 ends with the baking node's final event
  EXPECT_EQ(last.state(), v1::JOB_STATE_CANCELLED);
  EXPECT_TRUE(last.final());
  EXPECT_EQ(connect(*nodes_[0]).result(id).state(), v1::JOB_STATE_CANCELLED);
  // The baking node's worker is free again (its own count follows the farm's final event by a moment).
  EXPECT_TRUE(eventually([&] { return running_on(0) + running_on(1) + running_on(2) == 0; }));
}

}  // namespace
}  // namespace kiln::test

namespace kiln::test {
namespace {

// Two nodes whose shared store may hold 1 byte, with no grace: every blob no job reads is evicted at the next pass
// of the farm's retention, which a submit asks for.
class FarmStoreLimitTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (RedisServer::binary().empty()) GTEST_SKIP() << RedisServer::kSkipMessage;
    redis_ = std::make_unique<RedisServer>();
    const std::filesystem::path shared = redis_->dir() / "shared-store";
    for (int i = 0; i < 2; ++i) {
      nodes_.push_back(std::make_unique<Daemon>(std::vector<std::string>{
          "--cluster", redis_->url(), "--store", shared.string(), "--node-name", "node" + std::to_string(i),
          "--store-limit-bytes", "1", "--cluster-eviction-grace", "0"}));
    }
  }
  v1::JobResult wait_finished(client::Client& c, const std::string& id) {
    v1::JobResult r;
    EXPECT_TRUE(eventually([&] { return finished((r = c.result(id)).state()); }));
    return r;
  }
  std::unique_ptr<RedisServer> redis_;
  std::vector<std::unique_ptr<Daemon>> nodes_;
};

TEST_F(FarmStoreLimitTest, AnEvictedResultLeavesTheFarmsCacheAndTheJobBakesAgain) {
  client::Client a = connect(*nodes_[0]);
  client::Client b = connect(*nodes_[1]);
  const std::string first = a.submit(tiny_job(0)).job_id();
  ASSERT_EQ(wait_finished(a, first).state(), v1::JOB_STATE_SUCCEEDED);
  // A submit asks for a pass; whichever node takes the lock evicts job 0's outputs (nothing pins them, and they
  // were last used before it). Until then its result is served; afterwards both nodes say its outputs were evicted.
  b.submit(tiny_job(1));
  bool evicted = false;
  ASSERT_TRUE(eventually([&] {
    try {
      b.result(first);
    } catch (const client::ServerError& e) {
      EXPECT_EQ(e.code(), v1::Error::NOT_FOUND);
      evicted = std::string(e.what()).find("evicted") != std::string::npos;
      return true;
    }
    return false;
  })) << "job 0's outputs were never evicted; node 0's log:\n"
      << nodes_[0]->log() << "\nnode 1's log:\n"
      << nodes_[1]->log();
  EXPECT_TRUE(evicted);
  // The same job through the other node: not answered from the cache with outputs that are gone, but baked again.
  const v1::SubmitReply again = b.submit(tiny_job(0));
  EXPECT_FALSE(again.cache_hit());
  EXPECT_EQ(wait_finished(b, again.job_id()).state(), v1::JOB_STATE_SUCCEEDED);
  cluster::RedisClient r(redis_->options());
  EXPECT_EQ(r.command({"HLEN", "kiln:pins"}).as_integer(), 0);
}

}  // namespace
}  // namespace kiln::test
