#include "daemon/cluster/farm_work_queue.h"

#include <algorithm>

namespace kiln::cluster {

namespace {

// An idle worker claims again after this even without a wake-up (one missed while the subscriber reconnected).
constexpr std::chrono::milliseconds kIdlePoll{500};
constexpr std::chrono::milliseconds kRetryAtMost{2000};

}  // namespace

bool FarmWorkQueue::push(const std::string&, int32_t, int64_t) { return !is_shut_down(); }

std::optional<store::QueuedJob> FarmWorkQueue::pop(std::stop_token stop) {
  thread_local const int index = next_worker_++;
  auto backoff = std::chrono::milliseconds(100);
  while (!stop.stop_requested() && !is_shut_down()) {
    std::optional<Claim> claim;
    const uint64_t ticket = node_->wake_ticket();
    try {
      FarmNode::Connection c = node_->connect();
      claim = node_->queue().claim(*c, index);
      node_->reachable();
      backoff = std::chrono::milliseconds(100);
    } catch (const RedisError& e) {
      // Stop taking work; the jobs running here go on. Claim again once Redis answers.
      node_->unreachable(e.what());
      node_->wait_for_work(ticket, backoff, stop);
      backoff = std::min(backoff * 2, kRetryAtMost);
      continue;
    }
    if (!claim) {
      node_->wait_for_work(ticket, kIdlePoll, stop);
      continue;
    }
    node_->hold(*claim);
    if (!node_->local().push(claim->job.id, claim->job.priority, claim->job.seq)) {
      // Shut down between the claim and here: the job goes back to the farm at once.
      finish(claim->job.id, store::Progress{store::JobState::queued, 0, {}, 0, {}, "handed back"});
      return std::nullopt;
    }
    if (auto job = node_->local().try_pop()) return job;
  }
  return std::nullopt;
}

store::CancelOutcome FarmWorkQueue::cancel(std::string_view id) {
  const store::CancelOutcome out = node_->call([&](RedisClient& redis) { return node_->jobs().cancel(redis, id); });
  // Running here: the flag at once, without waiting for the message to come back round.
  if (out == store::CancelOutcome::signalled) {
    if (auto flag = node_->local().cancel_flag(id)) *flag = true;
  }
  return out;
}

std::shared_ptr<std::atomic<bool>> FarmWorkQueue::cancel_flag(std::string_view id) {
  return node_->local().cancel_flag(id);
}

size_t FarmWorkQueue::size() const {
  return node_->call([&](RedisClient& redis) { return static_cast<size_t>(node_->jobs().counts(redis).jobs.queued); });
}

size_t FarmWorkQueue::running() const { return node_->local().running(); }

std::vector<std::string> FarmWorkQueue::running_ids() const { return node_->local().running_ids(); }

void FarmWorkQueue::shutdown() { node_->local().shutdown(); }

bool FarmWorkQueue::is_shut_down() const { return node_->local().is_shut_down(); }

void FarmWorkQueue::publish(std::string_view id, store::Progress progress) {
  node_->local().publish(id, progress);
  try {
    FarmNode::Connection c = node_->connect();
    node_->queue().publish(*c, std::string(id), progress);
  } catch (const RedisError& e) {
    node_->unreachable(e.what());  // progress is best effort; the job's end is not (FarmRecords waits for Redis)
  }
}

void FarmWorkQueue::finish(std::string_view id, store::Progress final_progress) {
  const std::string key(id);
  if (final_progress.state == store::JobState::queued) {
    if (const auto claim = node_->claim_of(key); claim && !node_->lost(key)) {
      try {
        FarmNode::Connection c = node_->connect();
        node_->queue().requeue(*c, *claim);
      } catch (const RedisError& e) {
        // Not handed back: its lease runs out and another node reclaims it.
        node_->unreachable(e.what());
      }
    }
    node_->release(key);
  }
  node_->local().finish(id, final_progress);
  node_->mirror().finish(id, final_progress);
}

store::Subscription FarmWorkQueue::subscribe(std::string_view id, Callback callback) {
  if (auto s = node_->local().subscribe(id, callback)) return s;
  const std::optional<store::Progress> latest =
      node_->call([&](RedisClient& redis) { return node_->jobs().latest(redis, id); });
  // Finished or unknown: the service answers from the records.
  if (!latest || store::is_terminal(latest->state)) return {};
  // Tracked in the mirror (never popped) while watched here; the subscriber feeds it the job's events.
  node_->mirror().push(std::string(id), 0, 0);
  node_->mirror().publish(id, *latest);
  node_->watch(std::string(id));
  return node_->mirror().subscribe(id, std::move(callback));
}

}  // namespace kiln::cluster
