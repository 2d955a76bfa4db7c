#include "daemon/cluster/farm_records.h"

#include <algorithm>
#include <thread>

#include "daemon/store/crash_point.h"

namespace kiln::cluster {

namespace {

[[noreturn]] void not_held(std::string_view id) {
  throw store::StoreError(store::StoreErrc::failed_precondition,
                          "job " + std::string(id.substr(0, 80)) + " is not running on this node");
}

}  // namespace

template <class F>
auto FarmRecords::persist(F&& f) {
  auto wait = std::chrono::milliseconds(100);
  for (;;) {
    try {
      return node_->call(f);
    } catch (const store::StoreError& e) {
      if (e.code() != store::StoreErrc::unavailable) throw;
    }
    std::this_thread::sleep_for(wait);
    wait = std::min(wait * 2, std::chrono::milliseconds(2000));
  }
}

store::JobRecord FarmRecords::current(std::string_view id) {
  auto r = persist([&](RedisClient& redis) { return node_->jobs().get(redis, id); });
  if (!r) throw store::StoreError(store::StoreErrc::not_found, "no job " + std::string(id.substr(0, 80)));
  return *r;
}

store::InsertOutcome FarmRecords::insert(const store::NewJob& job) {
  return node_->call(
      [&](RedisClient& redis) { return node_->jobs().insert(redis, job, node_->config().max_queued_jobs); });
}

std::optional<store::JobRecord> FarmRecords::get(std::string_view id) {
  return node_->call([&](RedisClient& redis) { return node_->jobs().get(redis, id); });
}

std::optional<store::JobRecord> FarmRecords::find_succeeded_by_spec_key(std::string_view spec_key) {
  return node_->call([&](RedisClient& redis) { return node_->jobs().find_succeeded_by_spec_key(redis, spec_key); });
}

store::JobRecord FarmRecords::mark_running(std::string_view id) {
  const auto claim = node_->claim_of(std::string(id));
  if (!claim) not_held(id);
  store::crash_point("job.running");  // the farm's test kills a node here, its claim held and its bake not done
  return claim->job;
}

store::JobRecord FarmRecords::end_claimed(const Claim& claim, const char* outcome, std::string_view text,
                                          const std::vector<std::string>& outputs) {
  const std::string& id = claim.job.id;
  if (!node_->lost(id)) {
    const CommitOutcome done = persist([&](RedisClient& redis) {
      const std::string t(text);
      if (std::string_view(outcome) == "succeeded") return node_->queue().commit_success(redis, claim, t, outputs);
      if (std::string_view(outcome) == "failed") return node_->queue().commit_failure(redis, claim, t);
      return node_->queue().commit_cancelled(redis, claim);
    });
    if (done == CommitOutcome::duplicate) {
      node_->config().log("job " + id, std::string("this run's end (") + outcome +
                                           ") was discarded: another node's run of the job ended first");
    }
  }
  node_->release(id);
  return current(id);
}

store::JobRecord FarmRecords::mark_succeeded(std::string_view id, std::string_view result,
                                             const std::vector<std::string>& output_digests) {
  const auto claim = node_->claim_of(std::string(id));
  if (!claim) not_held(id);
  return end_claimed(*claim, "succeeded", result, output_digests);
}

store::JobRecord FarmRecords::mark_failed(std::string_view id, std::string_view error) {
  const auto claim = node_->claim_of(std::string(id));
  if (!claim) not_held(id);
  return end_claimed(*claim, "failed", error, {});
}

store::JobRecord FarmRecords::mark_cancelled(std::string_view id) {
  if (const auto claim = node_->claim_of(std::string(id))) return end_claimed(*claim, "cancelled", "", {});
  const store::JobRecord r = current(id);
  if (r.state == store::JobState::cancelled) return r;
  if (store::is_terminal(r.state)) {
    throw store::StoreError(
        store::StoreErrc::failed_precondition,
        "job " + r.id + " is " + std::string(store::to_string(r.state)) + "; it cannot be cancelled");
  }
  node_->call([&](RedisClient& redis) { return node_->jobs().cancel(redis, id); });
  return current(id);
}

store::JobRecord FarmRecords::mark_queued(std::string_view id) {
  const auto claim = node_->claim_of(std::string(id));
  if (!claim) not_held(id);
  const bool lost = node_->lost(claim->job.id);
  node_->release(claim->job.id);
  // Not retried: this is a node stopping, which must not wait for Redis. A job not handed back runs elsewhere once
  // its lease runs out.
  if (!lost) {
    try {
      node_->call([&](RedisClient& redis) { return node_->queue().requeue(redis, *claim); });
    } catch (const store::StoreError& e) {
      node_->config().log("job " + claim->job.id,
                          std::string("not handed back (") + e.what() + "); it runs elsewhere after its lease");
      return claim->job;
    }
  }
  return current(id);
}

std::vector<store::JobRecord> FarmRecords::list(size_t limit, std::optional<store::JobState> state,
                                                std::optional<int64_t> before_seq) {
  return node_->call([&](RedisClient& redis) { return node_->jobs().list(redis, limit, state, before_seq); });
}

store::JobCounts FarmRecords::counts() {
  return node_->call([&](RedisClient& redis) { return node_->jobs().counts(redis).jobs; });
}

bool FarmRecords::touch(std::string_view id, std::optional<double> when) {
  return node_->call([&](RedisClient& redis) { return node_->jobs().touch(redis, id, when); });
}

size_t FarmRecords::mark_results_evicted(const std::unordered_set<std::string>& removed_digests) {
  const std::vector<std::string> digests(removed_digests.begin(), removed_digests.end());
  return node_->call([&](RedisClient& redis) { return node_->jobs().mark_results_evicted(redis, digests); });
}

}  // namespace kiln::cluster
