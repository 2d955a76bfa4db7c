#include "daemon/cluster/farm_housekeeper.h"

namespace kiln::cluster {

namespace {

// Passes that submits ask for are at least this far apart: each one lists the shared store.
constexpr std::chrono::seconds kMinGap{1};

}  // namespace

FarmHousekeeper::FarmHousekeeper(std::shared_ptr<FarmNode> node, store::BlobStore& blobs,
                                 FarmRetentionOptions options, std::chrono::milliseconds period)
    : node_(std::move(node)), retention_(std::move(options), blobs), period_(period) {
  thread_ = std::jthread([this](std::stop_token stop) { loop(stop); });
}

FarmHousekeeper::~FarmHousekeeper() {
  thread_.request_stop();
  if (thread_.joinable()) thread_.join();
}

void FarmHousekeeper::poke() {
  if (retention_.options().store_limit_bytes == 0) return;
  {
    std::lock_guard lock(mu_);
    poked_ = true;
  }
  wake_.notify_one();
}

void FarmHousekeeper::stored(const std::string& digest) {
  try {
    node_->call([&](RedisClient& redis) {
      retention_.stored(redis, digest);
      return 0;
    });
  } catch (const store::StoreError& e) {
    node_->config().log("blob " + digest, std::string("stored, but its use was not recorded in Redis: ") + e.what());
  }
}

void FarmHousekeeper::loop(std::stop_token stop) {
  while (!stop.stop_requested()) {
    {
      std::unique_lock lock(mu_);
      wake_.wait_for(lock, stop, period_, [this] { return poked_; });
      poked_ = false;
    }
    if (stop.stop_requested()) return;
    pass();
    std::unique_lock lock(mu_);
    wake_.wait_for(lock, stop, kMinGap, [] { return false; });
  }
}

void FarmHousekeeper::pass() {
  const std::string& log_subject = "farm retention";
  try {
    const FarmRetentionReport r = node_->call([&](RedisClient& redis) { return retention_.run(redis); });
    if (r.jobs_expired > 0) {
      node_->config().log(log_subject, "deleted the records of " + std::to_string(r.jobs_expired) +
                                           " finished job(s) unused for longer than cluster_job_retention_seconds");
    }
    if (!r.blobs.removed.empty()) {
      node_->config().log(log_subject, "evicted " + std::to_string(r.blobs.removed.size()) + " blob(s), " +
                                           std::to_string(r.blobs.bytes_freed) + " bytes, " +
                                           std::to_string(r.results_evicted) + " result(s) left the cache");
    }
    // Said once when it starts, not at every pass while it lasts.
    const bool was_over = over_limit_;
    if (r.ran) over_limit_ = r.blobs.limit_unreachable;
    if (over_limit_ && !was_over) {
      node_->config().log(log_subject, "the shared store holds " + std::to_string(r.blobs.bytes_after) +
                                           " bytes, over store_limit_bytes, but the rest is pinned by queued or "
                                           "running jobs or used within cluster_eviction_grace_seconds");
    }
  } catch (const std::exception& e) {
    node_->config().log(log_subject, std::string("pass skipped: ") + e.what());
  }
}

}  // namespace kiln::cluster
