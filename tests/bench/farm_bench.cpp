// The farm's coordination cost (docs/SCALING.md): what Redis costs a job, measured without baking. Each node is a
// farm node in this process (its own connections, subscriber and lease keeper, as in kilnd) with one worker that
// does a worker's part with an empty bake: claim, mark running, commit the result, finish. Against a real
// redis-server on a Unix socket with the shipped durability (appendfsync always) or the cheaper everysec.
//
//   farm_bench --benchmark_counters_tabular=true
//
// FarmThroughput/N/F: N nodes drain 400 queued jobs; jobs/s, and Redis round trips per job over every node's
// threads (idle polling and lease renewals included). F = 1: appendfsync always, 0: everysec.
// SubmitToStart: one idle node; milliseconds from a submit's call to the worker holding the job (median, p90),
// one job at a time, and the round trips per job of that whole cycle.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <atomic>
#include <thread>
#include <vector>

#include "daemon/cluster/farm.h"
#include "tests/cluster/redis_server.h"

namespace kiln {
namespace {

using Clock = std::chrono::steady_clock;

store::NewJob tiny(int i) {
  store::NewJob j;
  j.name = "bench " + std::to_string(i);
  j.type = "material";
  j.spec = "a spec of about the size of a small material job's: " + std::string(64, 's');
  j.spec_key = "bench key " + std::to_string(i);
  return j;
}

cluster::Farm node(const test::RedisServer& redis, const std::string& name) {
  cluster::FarmConfig c;
  c.url = redis.url();
  c.node = name;
  c.max_queued_jobs = 0;
  return cluster::join_farm(c);
}

// A worker with an empty bake; `started` (if given) is told when it holds each job, `done` counts the jobs ended.
void work(cluster::Farm& f, std::stop_token stop, std::atomic<int>& done, const std::function<void()>& started = {}) {
  while (auto job = f.queue->pop(stop)) {
    if (started) started();
    f.records->mark_running(job->id);
    f.records->mark_succeeded(job->id, "a result", {});
    f.queue->finish(job->id, store::Progress{store::JobState::succeeded, 1, {}, 0, {}, "done"});
    ++done;
    done.notify_all();
  }
}

// Blocks until `counter` reaches `target` (no polling: the workers notify).
void wait_for(std::atomic<int>& counter, int target) {
  for (int seen = counter; seen < target; seen = counter) counter.wait(seen);
}

void FarmThroughput(benchmark::State& state) {
  if (test::RedisServer::binary().empty()) return state.SkipWithError(test::RedisServer::kSkipMessage);
  const int nodes = static_cast<int>(state.range(0));
  const bool always = state.range(1) == 1;
  constexpr int kJobs = 400;
  for (auto _ : state) {
    test::RedisServer redis({"--appendfsync", always ? "always" : "everysec"});
    cluster::Farm front = node(redis, "front");
    const auto s0 = Clock::now();
    for (int i = 0; i < kJobs; ++i) front.records->insert(tiny(i));
    const double submit_s = std::chrono::duration<double>(Clock::now() - s0).count();
    std::vector<cluster::Farm> farm;
    for (int n = 0; n < nodes; ++n) farm.push_back(node(redis, "n" + std::to_string(n)));
    std::atomic<int> done{0};
    const auto t0 = Clock::now();
    std::vector<std::jthread> workers;
    for (auto& f : farm) workers.emplace_back([&f, &done](std::stop_token stop) { work(f, stop, done); });
    wait_for(done, kJobs);
    const double drain_s = std::chrono::duration<double>(Clock::now() - t0).count();
    state.SetIterationTime(drain_s);
    uint64_t trips = 0;
    for (auto& f : farm) trips += f.node->round_trips();
    for (auto& f : farm) f.queue->shutdown();
    state.counters["jobs_per_s"] = kJobs / drain_s;
    state.counters["submit_ms"] = 1000 * submit_s / kJobs;
    state.counters["worker_trips_per_job"] = static_cast<double>(trips) / kJobs;
    state.counters["submit_trips_per_job"] = static_cast<double>(front.node->round_trips()) / kJobs;
  }
}
BENCHMARK(FarmThroughput)
    ->ArgsProduct({{1, 2, 4, 8}, {1, 0}})
    ->Iterations(1)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);

void SubmitToStart(benchmark::State& state) {
  if (test::RedisServer::binary().empty()) return state.SkipWithError(test::RedisServer::kSkipMessage);
  constexpr int kJobs = 100;
  for (auto _ : state) {
    test::RedisServer redis({"--appendfsync", "always"});
    cluster::Farm front = node(redis, "front");
    cluster::Farm worker = node(redis, "worker");
    std::atomic<int64_t> started_ns{0};
    std::atomic<int> done{0};
    std::jthread thread([&](std::stop_token stop) {
      work(worker, stop, done, [&] {
        started_ns = Clock::now().time_since_epoch().count();
        started_ns.notify_all();
      });
    });
    std::vector<double> ms;
    const uint64_t trips0 = front.node->round_trips() + worker.node->round_trips();
    for (int i = 0; i < kJobs; ++i) {
      started_ns = 0;
      const auto submitted = Clock::now();
      front.records->insert(tiny(i));
      started_ns.wait(0);
      ms.push_back(1e-6 * static_cast<double>(started_ns - submitted.time_since_epoch().count()));
      wait_for(done, i + 1);
    }
    const uint64_t trips = front.node->round_trips() + worker.node->round_trips() - trips0;
    worker.queue->shutdown();
    std::sort(ms.begin(), ms.end());
    state.SetIterationTime(ms[kJobs / 2] / 1000);
    state.counters["median_ms"] = ms[kJobs / 2];
    state.counters["p90_ms"] = ms[kJobs * 9 / 10];
    state.counters["trips_per_job"] = static_cast<double>(trips) / kJobs;
  }
}
BENCHMARK(SubmitToStart)->Iterations(1)->UseManualTime()->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace kiln

BENCHMARK_MAIN();
