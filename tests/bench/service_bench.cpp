// What the service costs: a cache-hit submit's round trip, small material jobs per second with 1 and 2 workers,
// upload and download speed on loopback, and what TLS adds (argument 1: kilnd with --tls-cert, the client with the
// test CA) to connecting, a round trip and a download. Each benchmark starts its own kilnd (tests/integration's
// fixture).
//   build/tests/service_bench --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <atomic>
#include <memory>
#include <random>
#include <thread>

#include "client/lib/client.h"
#include "proto/kiln.pb.h"
#include "tests/integration/daemon_fixture.h"
#include "tests/integration/test_certs.h"

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

// A kilnd with TLS when `tls`, and the options of a client that trusts it.
struct Endpoint {
  explicit Endpoint(bool tls)
      : daemon(tls ? std::vector<std::string>{"--tls-cert", kiln::test::cert("server.pem"), "--tls-key",
                                              kiln::test::cert("server.key")}
                   : std::vector<std::string>{}) {
    if (tls) options.tls.ca_file = kiln::test::cert("ca.pem");
  }
  Client connect() const {
    Client c(daemon.tcp(), options);
    c.hello(daemon.token());
    return c;
  }
  Daemon daemon;
  kiln::client::Options options;
};

const char* tls_label(const benchmark::State& state) { return state.range(0) ? "TLS" : "plain"; }

// Connecting and saying hello: with TLS, the handshake (ECDHE P-256, an ECDSA certificate) is in it.
void BM_ConnectAndHello(benchmark::State& state) {
  const Endpoint e(state.range(0) != 0);
  for (auto _ : state) e.connect();
  state.SetLabel(tls_label(state));
}
BENCHMARK(BM_ConnectAndHello)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond)->UseRealTime()->MinTime(2.0);

void BM_StatusRoundTrip(benchmark::State& state) {
  const Endpoint e(state.range(0) != 0);
  Client c = e.connect();
  for (auto _ : state) benchmark::DoNotOptimize(c.status());
  state.SetLabel(tls_label(state));
}
BENCHMARK(BM_StatusRoundTrip)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond)->UseRealTime()->MinTime(2.0);

// 16 MiB fetched and verified, as BM_Download, plain and over TLS.
void BM_DownloadTls(benchmark::State& state) {
  const Endpoint e(state.range(0) != 0);
  Client c = e.connect();
  const std::string blob = random_bytes(16 << 20, 9);
  const v1::Digest digest = c.upload_blob(blob);
  for (auto _ : state) benchmark::DoNotOptimize(c.fetch(digest));
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * (16 << 20));
  state.SetLabel(tls_label(state));
}
BENCHMARK(BM_DownloadTls)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);

BENCHMARK_MAIN();
