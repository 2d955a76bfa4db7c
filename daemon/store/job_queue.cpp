#include "daemon/store/job_queue.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <set>
#include <tuple>
#include <unordered_map>
#include <utility>

namespace kiln::store {

struct Subscription::State {
  std::weak_ptr<JobQueue::Impl> queue;
  std::string job_id;
  uint64_t key = 0;
  const JobQueue::Callback callback;  // never changes, so a delivery may call it without a lock

  std::mutex mu;  // guards the flow-control fields below
  bool in_flight = false;
  bool closed = false;
  std::optional<Progress> pending;  // the latest update published while one was in flight

  State(std::weak_ptr<JobQueue::Impl> q, std::string id, uint64_t k, JobQueue::Callback cb)
      : queue(std::move(q)), job_id(std::move(id)), key(k), callback(std::move(cb)) {}
};

namespace {

using SubPtr = std::shared_ptr<Subscription::State>;
// Deliveries are decided under the queue's lock (so they follow publication order) and run after it is released
// (so a callback may call back into the queue).
using Deliveries = std::vector<std::pair<SubPtr, Progress>>;

void run(Deliveries& ds) {
  for (auto& [sub, p] : ds) sub->callback(p);
}

// Under the queue's lock: either deliver now, or keep as the pending (latest) update.
void offer(const SubPtr& sub, const Progress& p, Deliveries& out) {
  std::lock_guard lock(sub->mu);
  if (sub->closed) return;
  if (sub->in_flight) {
    sub->pending = p;  // coalesce: latest wins
    return;
  }
  sub->in_flight = true;
  out.emplace_back(sub, p);
}

Progress sanitize(Progress p) {
  // Nothing non-finite reaches a watcher, whatever a baker reports.
  p.fraction = std::isfinite(p.fraction) ? std::clamp(p.fraction, 0.0, 1.0) : 0.0;
  if (p.eta_seconds && !(std::isfinite(*p.eta_seconds) && *p.eta_seconds >= 0)) p.eta_seconds.reset();
  if (p.error_estimate && !(std::isfinite(*p.error_estimate) && *p.error_estimate >= 0)) p.error_estimate.reset();
  return p;
}

}  // namespace

struct JobQueue::Impl {
  enum class Where { waiting, running, removed };
  struct Tracked {
    int32_t priority = 0;
    int64_t seq = 0;
    Where where = Where::waiting;
    std::shared_ptr<std::atomic<bool>> cancel = std::make_shared<std::atomic<bool>>(false);
    Progress latest;
    std::map<uint64_t, SubPtr> subs;
  };
  // Ordered by the order jobs run in: higher priority first, then lower seq (earlier arrival).
  struct Key {
    int32_t priority;
    int64_t seq;
    std::string id;
    bool operator<(const Key& o) const {
      if (priority != o.priority) return priority > o.priority;
      if (seq != o.seq) return seq < o.seq;
      return id < o.id;
    }
  };

  mutable std::mutex mu;
  std::condition_variable_any cv;
  std::set<Key> waiting;
  // Transparent hashing is C++20 but not in every standard library yet; job ids are short, so copying is fine.
  std::unordered_map<std::string, Tracked> tracked;
  size_t n_running = 0;
  bool shut_down = false;
  uint64_t next_sub = 1;

  void notify_locked(Tracked& t, Deliveries& out) {
    for (auto& [k, sub] : t.subs) offer(sub, t.latest, out);
  }

  QueuedJob take_front_locked(Deliveries& out) {
    Key k = *waiting.begin();
    waiting.erase(waiting.begin());
    Tracked& t = tracked.at(k.id);
    t.where = Where::running;
    ++n_running;
    t.latest = Progress{};
    t.latest.state = JobState::running;
    notify_locked(t, out);
    return {k.id, k.priority, k.seq, t.cancel};
  }
};

// --- Subscription ---------------------------------------------------------------------------------------------

Subscription::~Subscription() { reset(); }

Subscription::Subscription(Subscription&& o) noexcept : state_(std::move(o.state_)) {}

Subscription& Subscription::operator=(Subscription&& o) noexcept {
  if (this != &o) {
    reset();
    state_ = std::move(o.state_);
  }
  return *this;
}

void Subscription::reset() {
  if (!state_) return;
  std::shared_ptr<State> s = std::move(state_);
  {
    std::lock_guard lock(s->mu);
    s->closed = true;
    s->pending.reset();
  }
  if (auto q = s->queue.lock()) {
    std::lock_guard lock(q->mu);
    if (auto it = q->tracked.find(s->job_id); it != q->tracked.end()) it->second.subs.erase(s->key);
  }
}

void Subscription::ready() {
  if (!state_) return;
  std::optional<Progress> next;
  {
    std::lock_guard lock(state_->mu);
    if (state_->closed) return;
    if (state_->pending) {
      next = std::move(state_->pending);
      state_->pending.reset();  // still in flight: this delivery needs its own ready()
    } else {
      state_->in_flight = false;
    }
  }
  if (next) state_->callback(*next);
}

// --- JobQueue -------------------------------------------------------------------------------------------------

JobQueue::JobQueue() : impl_(std::make_shared<Impl>()) {}

JobQueue::~JobQueue() { shutdown(); }

bool JobQueue::push(const std::string& id, int32_t priority, int64_t seq) {
  std::lock_guard lock(impl_->mu);
  if (impl_->shut_down || impl_->tracked.count(id)) return false;
  Impl::Tracked t;
  t.priority = priority;
  t.seq = seq;
  impl_->tracked.emplace(id, std::move(t));
  impl_->waiting.insert({priority, seq, id});
  impl_->cv.notify_one();
  return true;
}

std::optional<QueuedJob> JobQueue::pop(std::stop_token stop) {
  Deliveries ds;
  std::optional<QueuedJob> out;
  {
    std::unique_lock lock(impl_->mu);
    impl_->cv.wait(lock, stop, [&] { return impl_->shut_down || !impl_->waiting.empty(); });
    if (stop.stop_requested() || impl_->shut_down || impl_->waiting.empty()) return std::nullopt;
    out = impl_->take_front_locked(ds);
  }
  run(ds);
  return out;
}

std::optional<QueuedJob> JobQueue::try_pop() {
  Deliveries ds;
  std::optional<QueuedJob> out;
  {
    std::lock_guard lock(impl_->mu);
    if (impl_->shut_down || impl_->waiting.empty()) return std::nullopt;
    out = impl_->take_front_locked(ds);
  }
  run(ds);
  return out;
}

bool JobQueue::remove(std::string_view id) {
  std::lock_guard lock(impl_->mu);
  auto it = impl_->tracked.find(std::string(id));
  if (it == impl_->tracked.end() || it->second.where != Impl::Where::waiting) return false;
  impl_->waiting.erase({it->second.priority, it->second.seq, it->first});
  it->second.where = Impl::Where::removed;
  return true;
}

CancelOutcome JobQueue::cancel(std::string_view id) {
  std::lock_guard lock(impl_->mu);
  auto it = impl_->tracked.find(std::string(id));
  if (it == impl_->tracked.end()) return CancelOutcome::unknown;
  Impl::Tracked& t = it->second;
  t.cancel->store(true);
  switch (t.where) {
    case Impl::Where::waiting:
      impl_->waiting.erase({t.priority, t.seq, it->first});
      t.where = Impl::Where::removed;
      return CancelOutcome::removed_from_queue;
    case Impl::Where::removed:
      return CancelOutcome::removed_from_queue;
    case Impl::Where::running:
      return CancelOutcome::signalled;
  }
  return CancelOutcome::unknown;
}

std::shared_ptr<std::atomic<bool>> JobQueue::cancel_flag(std::string_view id) {
  std::lock_guard lock(impl_->mu);
  auto it = impl_->tracked.find(std::string(id));
  return it == impl_->tracked.end() ? nullptr : it->second.cancel;
}

size_t JobQueue::size() const {
  std::lock_guard lock(impl_->mu);
  return impl_->waiting.size();
}

size_t JobQueue::running() const {
  std::lock_guard lock(impl_->mu);
  return impl_->n_running;
}

bool JobQueue::is_queued(std::string_view id) const {
  std::lock_guard lock(impl_->mu);
  auto it = impl_->tracked.find(std::string(id));
  return it != impl_->tracked.end() && it->second.where == Impl::Where::waiting;
}

std::vector<std::string> JobQueue::running_ids() const {
  std::lock_guard lock(impl_->mu);
  std::vector<std::string> out;
  for (const auto& [id, t] : impl_->tracked)
    if (t.where == Impl::Where::running) out.push_back(id);
  std::sort(out.begin(), out.end());
  return out;
}

void JobQueue::shutdown() {
  {
    std::lock_guard lock(impl_->mu);
    impl_->shut_down = true;
  }
  impl_->cv.notify_all();
}

bool JobQueue::is_shut_down() const {
  std::lock_guard lock(impl_->mu);
  return impl_->shut_down;
}

void JobQueue::publish(std::string_view id, Progress progress) {
  Deliveries ds;
  {
    std::lock_guard lock(impl_->mu);
    auto it = impl_->tracked.find(std::string(id));
    if (it == impl_->tracked.end()) return;
    it->second.latest = sanitize(std::move(progress));
    impl_->notify_locked(it->second, ds);
  }
  run(ds);
}

void JobQueue::finish(std::string_view id, Progress final_progress) {
  Deliveries ds;
  {
    std::lock_guard lock(impl_->mu);
    auto it = impl_->tracked.find(std::string(id));
    if (it == impl_->tracked.end()) return;
    Impl::Tracked& t = it->second;
    t.latest = sanitize(std::move(final_progress));
    impl_->notify_locked(t, ds);
    if (t.where == Impl::Where::waiting) impl_->waiting.erase({t.priority, t.seq, it->first});
    if (t.where == Impl::Where::running) --impl_->n_running;
    // Subscriptions keep their pending final update; they just stop being reachable from the job.
    impl_->tracked.erase(it);
  }
  run(ds);
}

std::optional<Progress> JobQueue::latest(std::string_view id) const {
  std::lock_guard lock(impl_->mu);
  auto it = impl_->tracked.find(std::string(id));
  if (it == impl_->tracked.end()) return std::nullopt;
  return it->second.latest;
}

Subscription JobQueue::subscribe(std::string_view id, Callback callback) {
  Subscription handle;
  Deliveries ds;
  {
    std::lock_guard lock(impl_->mu);
    auto it = impl_->tracked.find(std::string(id));
    if (it == impl_->tracked.end() || !callback) return handle;
    uint64_t key = impl_->next_sub++;
    auto state = std::make_shared<Subscription::State>(impl_, it->first, key, std::move(callback));
    it->second.subs.emplace(key, state);
    offer(state, it->second.latest, ds);
    handle.state_ = std::move(state);
  }
  run(ds);
  return handle;
}

}  // namespace kiln::store
