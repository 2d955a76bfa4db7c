// JobQueue: priority-then-arrival order (also under concurrent producers and consumers), shutdown and stop tokens
// wake waiters, cancel flags, and progress subscriptions that coalesce to the latest snapshot.
#include "daemon/store/job_queue.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <limits>
#include <mutex>
#include <set>
#include <thread>
#include <vector>

using namespace kiln::store;

namespace {

std::string id_of(int i) { return "job-" + std::to_string(i); }

Progress at(double fraction, JobState state = JobState::running) {
  Progress p;
  p.state = state;
  p.fraction = fraction;
  return p;
}

// Records deliveries; never calls ready() by itself.
struct Recorder {
  std::mutex mu;
  std::vector<Progress> seen;
  JobQueue::Callback callback() {
    return [this](const Progress& p) {
      std::lock_guard lock(mu);
      seen.push_back(p);
    };
  }
  size_t count() {
    std::lock_guard lock(mu);
    return seen.size();
  }
  Progress last() {
    std::lock_guard lock(mu);
    return seen.back();
  }
};

}  // namespace

TEST(JobQueue, HigherPriorityFirstThenArrival) {
  JobQueue q;
  EXPECT_TRUE(q.push("a", 0, 1));
  EXPECT_TRUE(q.push("b", 5, 2));
  EXPECT_TRUE(q.push("c", 0, 3));
  EXPECT_TRUE(q.push("d", 5, 4));
  EXPECT_TRUE(q.push("e", -1, 5));
  EXPECT_FALSE(q.push("a", 9, 6));  // already tracked
  EXPECT_EQ(q.size(), 5u);
  std::vector<std::string> order;
  while (auto j = q.try_pop()) order.push_back(j->id);
  EXPECT_EQ(order, (std::vector<std::string>{"b", "d", "a", "c", "e"}));
  EXPECT_EQ(q.running(), 5u);
  EXPECT_EQ(q.size(), 0u);
}

TEST(JobQueue, ConcurrentProducersThenOneConsumerGetsExactOrder) {
  JobQueue q;
  constexpr int kProducers = 4, kPerProducer = 250;
  std::atomic<int64_t> next_seq{1};
  std::vector<std::thread> producers;
  for (int p = 0; p < kProducers; ++p)
    producers.emplace_back([&, p] {
      for (int i = 0; i < kPerProducer; ++i) {
        int n = p * kPerProducer + i;
        ASSERT_TRUE(q.push(id_of(n), (n * 7) % 5, next_seq.fetch_add(1)));
      }
    });
  for (auto& t : producers) t.join();
  ASSERT_EQ(q.size(), static_cast<size_t>(kProducers * kPerProducer));
  std::vector<QueuedJob> popped;
  while (auto j = q.try_pop()) popped.push_back(*j);
  ASSERT_EQ(popped.size(), static_cast<size_t>(kProducers * kPerProducer));
  for (size_t i = 1; i < popped.size(); ++i) {
    const auto& a = popped[i - 1];
    const auto& b = popped[i];
    EXPECT_TRUE(a.priority > b.priority || (a.priority == b.priority && a.seq < b.seq)) << a.id << " before " << b.id;
  }
}

TEST(JobQueue, ConcurrentProducersAndConsumersDeliverEachJobOnceInOrderPerConsumer) {
  JobQueue q;
  constexpr int kProducers = 3, kConsumers = 3, kPerProducer = 400;
  constexpr int kTotal = kProducers * kPerProducer;
  std::atomic<int64_t> next_seq{1};
  std::atomic<int> consumed{0};
  std::mutex mu;
  std::multiset<std::string> seen;
  std::vector<std::jthread> consumers;
  for (int c = 0; c < kConsumers; ++c)
    consumers.emplace_back([&](std::stop_token st) {
      while (auto j = q.pop(st)) {
        {
          std::lock_guard lock(mu);
          seen.insert(j->id);
        }
        q.finish(j->id, at(1, JobState::succeeded));
        if (++consumed == kTotal) q.shutdown();
      }
    });
  std::vector<std::thread> producers;
  for (int p = 0; p < kProducers; ++p)
    producers.emplace_back([&, p] {
      for (int i = 0; i < kPerProducer; ++i) q.push(id_of(p * kPerProducer + i), i % 4, next_seq.fetch_add(1));
    });
  for (auto& t : producers) t.join();
  for (auto& t : consumers) t.join();  // the consumer that takes the last job shuts the queue down
  EXPECT_EQ(seen.size(), static_cast<size_t>(kTotal));
  for (int n = 0; n < kTotal; ++n) EXPECT_EQ(seen.count(id_of(n)), 1u) << id_of(n);
  EXPECT_EQ(q.running(), 0u);
}

TEST(JobQueue, ConsumersDrainingAFullQueueEachSeeQueueOrder) {
  JobQueue q;
  constexpr int kJobs = 1000, kConsumers = 4;
  for (int n = 0; n < kJobs; ++n) q.push(id_of(n), (n * 13) % 7, n + 1);
  std::vector<std::vector<QueuedJob>> per(kConsumers);
  std::vector<std::thread> consumers;
  for (int c = 0; c < kConsumers; ++c)
    consumers.emplace_back([&, c] {
      while (auto j = q.try_pop()) per[c].push_back(*j);
    });
  for (auto& t : consumers) t.join();
  size_t total = 0;
  for (const auto& v : per) {
    total += v.size();
    // With no new arrivals, whatever one consumer takes later ranks after what it took earlier.
    for (size_t i = 1; i < v.size(); ++i)
      EXPECT_TRUE(v[i - 1].priority > v[i].priority || (v[i - 1].priority == v[i].priority && v[i - 1].seq < v[i].seq));
  }
  EXPECT_EQ(total, static_cast<size_t>(kJobs));
}

TEST(JobQueue, ShutdownWakesEveryWaiterAndRefusesPushes) {
  JobQueue q;
  std::atomic<int> returned_empty{0};
  std::vector<std::thread> waiters;
  for (int i = 0; i < 4; ++i)
    waiters.emplace_back([&] {
      if (!q.pop()) ++returned_empty;
    });
  q.shutdown();
  for (auto& t : waiters) t.join();  // would hang if a waiter were not woken
  EXPECT_EQ(returned_empty.load(), 4);
  EXPECT_TRUE(q.is_shut_down());
  EXPECT_FALSE(q.push("late", 0, 1));
  EXPECT_FALSE(q.pop());
}

TEST(JobQueue, StopTokenWakesOneWaiterOnly) {
  JobQueue q;
  std::atomic<bool> stopped_empty{false};
  std::jthread stopped([&](std::stop_token st) { stopped_empty = !q.pop(st).has_value(); });
  std::optional<QueuedJob> got;
  std::thread worker([&] { got = q.pop(); });
  stopped.request_stop();
  stopped.join();
  EXPECT_TRUE(stopped_empty.load());
  q.push("x", 0, 1);  // the other waiter is still there to take it
  worker.join();
  ASSERT_TRUE(got);
  EXPECT_EQ(got->id, "x");
}

TEST(JobQueue, RemoveAndCancel) {
  JobQueue q;
  q.push("run", 0, 1);
  q.push("wait", 0, 2);
  q.push("drop", 0, 3);
  auto running = q.pop();
  ASSERT_TRUE(running);
  ASSERT_EQ(running->id, "run");
  EXPECT_FALSE(running->cancel->load());

  EXPECT_TRUE(q.remove("drop"));
  EXPECT_FALSE(q.remove("drop"));
  EXPECT_FALSE(q.remove("run"));  // running, not waiting
  EXPECT_FALSE(q.is_queued("drop"));

  EXPECT_EQ(q.cancel("run"), CancelOutcome::signalled);
  EXPECT_TRUE(running->cancel->load());  // the flag the worker handed to the baker
  EXPECT_EQ(q.cancel_flag("run"), running->cancel);
  EXPECT_EQ(q.cancel("wait"), CancelOutcome::removed_from_queue);
  EXPECT_TRUE(q.cancel_flag("wait")->load());
  EXPECT_EQ(q.size(), 0u);
  EXPECT_FALSE(q.try_pop());  // a cancelled job never runs
  EXPECT_EQ(q.cancel("nobody"), CancelOutcome::unknown);
  EXPECT_EQ(q.running_ids(), std::vector<std::string>{"run"});

  q.finish("run", at(0.4, JobState::cancelled));
  q.finish("wait", at(0, JobState::cancelled));
  q.finish("drop", at(0, JobState::cancelled));
  EXPECT_EQ(q.cancel("run"), CancelOutcome::unknown);
  EXPECT_EQ(q.running(), 0u);
  EXPECT_FALSE(q.cancel_flag("run"));
  EXPECT_TRUE(q.push("run", 0, 4));  // once finished it may be queued again (a requeue after a shutdown)
}

TEST(JobQueue, SubscribersGetTheLatestAtOnceThenCoalescedUpdates) {
  JobQueue q;
  q.push("j", 0, 1);
  Recorder r;
  Subscription sub = q.subscribe("j", r.callback());
  ASSERT_TRUE(sub);
  ASSERT_EQ(r.count(), 1u);
  EXPECT_EQ(r.last().state, JobState::queued);
  // While the watcher has not said it is ready, updates coalesce: nothing is delivered, nothing piles up.
  q.try_pop();
  for (int i = 1; i <= 100; ++i) q.publish("j", at(i / 100.0));
  EXPECT_EQ(r.count(), 1u);
  sub.ready();  // the latest, at once
  ASSERT_EQ(r.count(), 2u);
  EXPECT_DOUBLE_EQ(r.last().fraction, 1.0);
  sub.ready();  // nothing newer: the next publish goes straight through
  EXPECT_EQ(r.count(), 2u);
  q.publish("j", at(0.5));
  EXPECT_EQ(r.count(), 3u);
  EXPECT_DOUBLE_EQ(r.last().fraction, 0.5);
}

TEST(JobQueue, FinishReachesAWatcherThatWasBusyAndLaterSubscribersGetNothing) {
  JobQueue q;
  q.push("j", 0, 1);
  Recorder r;
  Subscription sub = q.subscribe("j", r.callback());  // in flight: the initial snapshot
  q.try_pop();
  q.publish("j", at(0.3));
  Progress final = at(1, JobState::succeeded);
  final.samples = 4096;
  q.finish("j", final);
  EXPECT_EQ(r.count(), 1u);
  sub.ready();
  ASSERT_EQ(r.count(), 2u);
  EXPECT_EQ(r.last().state, JobState::succeeded);
  EXPECT_EQ(r.last().samples, 4096u);
  Recorder late;
  EXPECT_FALSE(q.subscribe("j", late.callback()));  // finished: the daemon answers from the database
  EXPECT_EQ(late.count(), 0u);
  EXPECT_FALSE(q.latest("j"));
}

TEST(JobQueue, NonFiniteProgressNeverReachesWatchers) {
  JobQueue q;
  q.push("j", 0, 1);
  Progress p;
  p.state = JobState::running;
  p.fraction = std::numeric_limits<double>::quiet_NaN();
  p.eta_seconds = std::numeric_limits<double>::infinity();
  p.error_estimate = -1;
  q.publish("j", p);
  Progress got = *q.latest("j");
  EXPECT_EQ(got.fraction, 0.0);
  EXPECT_FALSE(got.eta_seconds);
  EXPECT_FALSE(got.error_estimate);
  q.publish("j", at(7.5));
  EXPECT_EQ(q.latest("j")->fraction, 1.0);
  q.publish("nobody", at(0.5));  // untracked: ignored
}

TEST(JobQueue, DroppedSubscriptionsGoQuietAndMayOutliveTheQueue) {
  Recorder r;
  Subscription kept;
  {
    JobQueue q;
    q.push("j", 0, 1);
    {
      Subscription dropped = q.subscribe("j", r.callback());
      dropped.ready();
    }
    EXPECT_EQ(r.count(), 1u);
    q.publish("j", at(0.5));
    EXPECT_EQ(r.count(), 1u);  // gone
    kept = q.subscribe("j", r.callback());
    EXPECT_EQ(r.count(), 2u);
  }
  kept.ready();  // the queue is gone: nothing happens, nothing crashes
  kept.reset();
  EXPECT_EQ(r.count(), 2u);
}

TEST(JobQueue, AWatcherOnAnotherThreadEndsWithTheFinalStateAndNeverGoesBackwards) {
  JobQueue q;
  q.push("j", 0, 1);
  std::mutex mu;
  std::condition_variable cv;
  std::deque<Progress> inbox;  // what a session's strand would hold: at most one event at a time
  Subscription sub = q.subscribe("j", [&](const Progress& p) {
    std::lock_guard lock(mu);
    inbox.push_back(p);
    cv.notify_one();
  });
  std::vector<Progress> delivered;
  std::thread watcher([&] {
    for (;;) {
      Progress p;
      {
        std::unique_lock lock(mu);
        cv.wait(lock, [&] { return !inbox.empty(); });
        EXPECT_EQ(inbox.size(), 1u);  // flow control: never a backlog
        p = inbox.front();
        inbox.pop_front();
      }
      delivered.push_back(p);
      if (is_terminal(p.state)) return;
      sub.ready();  // "my write finished"
    }
  });
  std::thread worker([&] {
    ASSERT_TRUE(q.pop());
    constexpr int kSteps = 5000;
    for (int i = 1; i <= kSteps; ++i) {
      Progress p = at(static_cast<double>(i) / kSteps);
      p.samples = static_cast<uint64_t>(i);
      q.publish("j", p);
    }
    Progress done = at(1, JobState::succeeded);
    done.samples = kSteps;
    q.finish("j", done);
  });
  worker.join();
  watcher.join();
  ASSERT_FALSE(delivered.empty());
  EXPECT_EQ(delivered.back().state, JobState::succeeded);
  for (size_t i = 1; i < delivered.size(); ++i) EXPECT_GE(delivered[i].samples, delivered[i - 1].samples);
}
