#include "bakers/envmap/dfg_cache.h"

#include <tuple>

#include "bakers/bake/bounded_cache.h"

namespace kiln::envmap {

std::shared_ptr<const DfgTable> cached_dfg(EnvLobe lobe, brdf::Masking masking, int size,
                                           const brdf::AlbedoOptions& options, bool* hit) {
  const auto build = [&] { return compute_dfg(lobe_model(lobe, masking), size, size, options); };
  if (static_cast<long long>(size) * size > kDfgCacheMaxEntries) {
    if (hit) *hit = false;
    return std::make_shared<const DfgTable>(build());
  }
  using Key = std::tuple<int, int, int, int, int, uint64_t>;
  static bake::BoundedCache<Key, DfgTable> cache(kDfgCacheTables);
  const Key key{static_cast<int>(lobe), static_cast<int>(masking), size,
                options.samples,        options.replicates,        options.seed};
  return cache.get(key, build, hit);
}

}  // namespace kiln::envmap
