// The process's DFG cache: the same arguments give the table compute_dfg gives, bit for bit, the second time from
// the cache; any argument that changes the table is another entry; concurrent bakes share it safely.
#include "bakers/envmap/dfg_cache.h"

#include <gtest/gtest.h>

#include <thread>
#include <tuple>
#include <vector>

namespace kiln::envmap {
namespace {

bool same(const DfgTable& a, const DfgTable& b) {
  if (a.size_mu != b.size_mu || a.size_roughness != b.size_roughness || a.entries.size() != b.entries.size())
    return false;
  for (size_t k = 0; k < a.entries.size(); ++k) {
    const DfgEntry &x = a.entries[k], &y = b.entries[k];
    if (x.scale != y.scale || x.bias != y.bias || x.energy != y.energy || x.scale_error != y.scale_error) return false;
  }
  return true;
}

brdf::AlbedoOptions options(int samples, uint64_t seed) {
  brdf::AlbedoOptions o;
  o.samples = samples;
  o.seed = seed;
  return o;
}

TEST(DfgCache, TheSecondAskIsAHitWithTheSameTable) {
  const brdf::Masking hc = brdf::Masking::height_correlated;
  DfgSource source = DfgSource::process;
  const auto first = cached_dfg(EnvLobe::ggx, hc, 8, options(64, 11), &source);
  EXPECT_EQ(source, DfgSource::computed);
  const auto second = cached_dfg(EnvLobe::ggx, hc, 8, options(64, 11), &source);
  EXPECT_EQ(source, DfgSource::process);
  EXPECT_EQ(first.get(), second.get());
  EXPECT_TRUE(same(*first, compute_dfg(lobe_model(EnvLobe::ggx, hc), 8, 8, options(64, 11))));
  // Every argument that changes the table is another entry.
  for (const auto& [lobe, masking, size, samples, seed] :
       {std::tuple{EnvLobe::beckmann, hc, 8, 64, uint64_t{11}},
        std::tuple{EnvLobe::ggx, brdf::Masking::separable, 8, 64, uint64_t{11}},
        std::tuple{EnvLobe::ggx, hc, 4, 64, uint64_t{11}}, std::tuple{EnvLobe::ggx, hc, 8, 32, uint64_t{11}},
        std::tuple{EnvLobe::ggx, hc, 8, 64, uint64_t{12}}}) {
    const auto other = cached_dfg(lobe, masking, size, options(samples, seed), &source);
    EXPECT_EQ(source, DfgSource::computed);
    EXPECT_TRUE(same(*other, compute_dfg(lobe_model(lobe, masking), size, size, options(samples, seed))));
  }
}

TEST(DfgCache, ItIsBoundedAndSharedSafelyBetweenThreads) {
  // More distinct tables than it keeps: the first is evicted, and asking again rebuilds the same table.
  const brdf::Masking hc = brdf::Masking::height_correlated;
  const auto first = cached_dfg(EnvLobe::ggx, hc, 4, options(16, 1000));
  for (int i = 1; i <= kDfgCacheTables; ++i) cached_dfg(EnvLobe::ggx, hc, 4, options(16, 1000 + i));
  DfgSource source = DfgSource::process;
  const auto again = cached_dfg(EnvLobe::ggx, hc, 4, options(16, 1000), &source);
  EXPECT_EQ(source, DfgSource::computed);
  EXPECT_TRUE(same(*first, *again));  // the evicted table is still valid where it was held
  // Threads asking for the same tables at once all get the same values.
  std::vector<std::thread> threads;
  std::vector<int> ok(8, 0);
  for (int t = 0; t < 8; ++t) {
    threads.emplace_back([&, t] {
      const auto table = cached_dfg(EnvLobe::ggx, hc, 4, options(16, 2000 + t % 2));
      ok[t] = same(*table, compute_dfg(lobe_model(EnvLobe::ggx, hc), 4, 4, options(16, 2000 + t % 2)));
    });
  }
  for (auto& th : threads) th.join();
  for (int t = 0; t < 8; ++t) EXPECT_TRUE(ok[t]) << t;
}

}  // namespace
}  // namespace kiln::envmap
