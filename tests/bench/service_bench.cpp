// What the service costs: a cache-hit submit's round trip, small material jobs per second with 1 and 2 workers,
// and upload and download speed on loopback. Each benchmark starts its own kilnd (tests/integration's fixture).
//   build/tests/service_bench --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <atomic>
#include <memory>
#include <random>
#include <thread>

#include "client/lib/client.h"
#include "proto/kiln.pb.h"
#include "tests/integration/daemon_fixture.h"

namespace {

using kiln::client::Client;
using kiln::test::Daemon;
namespace v1 = kiln::v1;

v1::JobSpec small_job(uint64_t seed) {
  v1::JobSpec spec;
  spec.mutable_material()->mutable_ggx()->set_alpha(0.3);
  spec.mutable_material()->set_table_mu(8);
  spec.mutable_material()->set_table_roughness(8);
  spec.mutable_quality()->set_samples(256);
  spec.mutable_quality()->set_seed(seed);  // a new seed is a new bake: no cache hit
  return spec;
}

void BM_CacheHitSubmit(benchmark::State& state) {
  Daemon d;
  Client c(d.tcp());
  c.hello(d.token());
  const auto first = c.submit(small_job(1));
  c.watch(first.job_id());
  for (auto _ : state) {
    const auto reply = c.submit(small_job(1));
    if (!reply.cache_hit()) state.SkipWithError("expected a cache hit");
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_CacheHitSubmit)->Unit(benchmark::kMicrosecond)->MinTime(2.0)->UseRealTime();

// Submits a batch of small jobs from 4 clients and waits for all: jobs per second through the whole service.
void BM_SmallJobs(benchmark::State& state) {
  const int workers = static_cast<int>(state.range(0));
  Daemon d({"--workers", std::to_string(workers), "--threads", std::to_string(workers)});
  std::atomic<uint64_t> seed{1000};
  constexpr int kClients = 4, kJobsPerClient = 5;
  for (auto _ : state) {
    std::vector<std::thread> clients;
    for (int k = 0; k < kClients; ++k) {
      clients.emplace_back([&] {
        Client c(d.tcp());
        c.hello(d.token());
        std::vector<std::string> ids;
        for (int j = 0; j < kJobsPerClient; ++j) ids.push_back(c.submit(small_job(seed++)).job_id());
        for (const auto& id : ids) c.watch(id);
      });
    }
    for (auto& t : clients) t.join();
  }
  state.SetItemsProcessed(state.iterations() * kClients * kJobsPerClient);
  state.SetLabel(std::to_string(workers) + " worker(s), 8x8 tables, 256 samples per entry");
}
BENCHMARK(BM_SmallJobs)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(3.0);

std::string random_bytes(size_t n, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::string s(n, '\0');
  for (size_t i = 0; i + 8 <= n; i += 8) {
    const uint64_t v = rng();
    std::memcpy(s.data() + i, &v, 8);
  }
  return s;
}

void BM_Upload(benchmark::State& state) {
  Daemon d;
  Client c(d.tcp());
  c.hello(d.token());
  std::string blob = random_bytes(static_cast<size_t>(state.range(0)), 7);
  uint64_t counter = 0;
  for (auto _ : state) {
    ++counter;
    std::memcpy(blob.data(), &counter, sizeof counter);  // new content, so the server stores it anew
    c.upload_blob(blob);
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * state.range(0));
}
BENCHMARK(BM_Upload)->Arg(16 << 20)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);

void BM_Download(benchmark::State& state) {
  Daemon d;
  Client c(d.tcp());
  c.hello(d.token());
  const std::string blob = random_bytes(static_cast<size_t>(state.range(0)), 9);
  const v1::Digest digest = c.upload_blob(blob);
  for (auto _ : state) benchmark::DoNotOptimize(c.fetch(digest));
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * state.range(0));
}
BENCHMARK(BM_Download)->Arg(16 << 20)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);

}  // namespace

BENCHMARK_MAIN();
