// A small thread-safe cache of immutable values built on demand, bounded by count: the oldest entries go first.
// For tables that depend on a few parameters only and cost more to build than to keep (Schlick's layer tables, an
// environment bake's DFG table). Two threads asking for the same new key may both build it; the first copy stored
// is kept and returned to both.
#pragma once

#include <cstddef>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>

namespace kiln::bake {

template <class Key, class Value>
class BoundedCache {
 public:
  explicit BoundedCache(size_t capacity) : capacity_(capacity) {}

  // The value for `key`, built by `build` if it is not held. `hit` (if given) says whether it was held.
  std::shared_ptr<const Value> get(const Key& key, const std::function<Value()>& build, bool* hit = nullptr) {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      if (auto it = cache_.find(key); it != cache_.end()) {
        if (hit) *hit = true;
        return it->second;
      }
    }
    if (hit) *hit = false;
    auto built = std::make_shared<const Value>(build());  // outside the lock: other keys are not held up
    const std::lock_guard<std::mutex> lock(mutex_);
    const auto [it, inserted] = cache_.emplace(key, std::move(built));
    if (inserted) {
      order_.push_back(key);
      if (order_.size() > capacity_) {
        cache_.erase(order_.front());
        order_.pop_front();
      }
    }
    return it->second;
  }

 private:
  const size_t capacity_;
  std::mutex mutex_;
  std::map<Key, std::shared_ptr<const Value>> cache_;
  std::deque<Key> order_;
};

}  // namespace kiln::bake
