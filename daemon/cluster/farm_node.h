// One kilnd node of a farm (docs/SCALING.md): its Redis connections, the claims it holds, and its two threads: the
// subscriber (cancels for its jobs, events for the jobs watched through it, wake-ups when jobs are queued) and the
// lease keeper (renews its claims, notices a cancel it missed and a lease it lost). farm_records.h and
// farm_work_queue.h present it to the service as store::JobRecords and store::WorkQueue.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <stop_token>
#include <string>
#include <thread>
#include <vector>

#include "daemon/cluster/farm_jobs.h"
#include "daemon/cluster/farm_queue.h"
#include "daemon/cluster/redis_client.h"
#include "daemon/store/job_queue.h"

namespace kiln::cluster {

struct FarmConfig {
  std::string url;       // redis://HOST:PORT[/DB] or unix:PATH[?db=DB]
  std::string password;  // from cluster_password_file; empty: none
  std::string node;      // this node's name in the farm, unique among its nodes
  std::string prefix = "kiln:";
  std::chrono::milliseconds lease{10000};
  int max_crash_restarts = 3;
  uint32_t max_queued_jobs = 1000;
  // kilnd's log (subject, message); the farm's code does not link the daemon's.
  std::function<void(const std::string&, const std::string&)> log = [](const std::string&, const std::string&) {};
};

class FarmNode {
 public:
  // Connects once, so that a wrong URL or password stops kilnd at start with the client's message (RedisError).
  explicit FarmNode(FarmConfig config);
  ~FarmNode();  // stops the threads
  FarmNode(const FarmNode&) = delete;
  FarmNode& operator=(const FarmNode&) = delete;

  // A connection for one call, back to the pool when the handle goes (RedisClient is one thread's at a time).
  class Connection {
   public:
    Connection(FarmNode& node, std::unique_ptr<RedisClient> client)
        : node_(node), client_(std::move(client)), start_(client_->round_trips()) {}
    ~Connection();
    Connection(const Connection&) = delete;
    Connection& operator=(const Connection&) = delete;
    RedisClient& operator*() { return *client_; }

   private:
    FarmNode& node_;
    std::unique_ptr<RedisClient> client_;
    uint64_t start_;
  };
  Connection connect();
  // One call `f(RedisClient&)` with a pooled connection. Redis out of reach becomes StoreError(unavailable) naming
  // the server (and the node notes the outage); any other Redis error StoreError(io).
  template <class F>
  auto call(F&& f) {
    try {
      Connection c = connect();
      auto result = f(*c);
      reachable();
      return result;
    } catch (const RedisError& e) {
      if (e.code() != RedisErrc::unavailable) throw store::StoreError(store::StoreErrc::io, e.what());
      unreachable(e.what());
      throw store::StoreError(store::StoreErrc::unavailable,
                              std::string(e.what()) + "; try again, or use another node of the farm");
    }
  }

  FarmJobs& jobs() { return jobs_; }
  FarmQueue& queue() { return queue_; }
  const FarmConfig& config() const { return config_; }
  // The jobs running here (cancel flags, progress for watchers connected here) and the remote jobs watched here.
  store::JobQueue& local() { return local_; }
  store::JobQueue& mirror() { return mirror_; }

  // --- Claims held by this node ---
  void hold(const Claim& claim);
  std::optional<Claim> claim_of(const std::string& id) const;
  void release(const std::string& id);
  // True once the lease keeper found another worker holds the job's entry: this node's run is no longer the job's.
  bool lost(const std::string& id) const;

  // --- Events of remote jobs ---
  // Subscribes to the job's events; the subscriber feeds them (and the job's latest state once subscribed) to
  // mirror(), and stops at the job's final event.
  void watch(const std::string& id);

  // Round trips to Redis this node made, from every thread (the farm benchmark's coordination cost).
  uint64_t round_trips() const { return round_trips_; }

  // --- Redis reachability ---
  // Notes that Redis answered, or that it did not (logged once per outage, naming the server and what the node does).
  void reachable();
  void unreachable(const std::string& why);
  // Wake-ups so far: take one before a claim, and wait_for_work returns at once if a job was queued since, so a
  // submit between the claim and the wait is not missed.
  uint64_t wake_ticket();
  // Waits until a job may be waiting (a wake-up after `ticket`), `timeout` passes or `stop` is requested.
  void wait_for_work(uint64_t ticket, std::chrono::milliseconds timeout, std::stop_token stop);

 private:
  void subscriber_loop(std::stop_token stop);
  void keeper_loop(std::stop_token stop);
  // Sends SUBSCRIBE for what is watched and not yet subscribed on `redis` (after a reconnection: everything).
  void subscribe_pending(RedisClient& redis, std::set<std::string>& subscribed);
  void on_message(RedisClient& redis, const std::string& channel, const std::string& payload);
  // Publishes the job's stored progress to mirror() (its final state ends the watch): after a subscription, so an
  // event published before it is not missed.
  void resync(const std::string& id);
  void renew_all(RedisClient& redis);

  FarmConfig config_;
  RedisOptions options_;
  FarmJobs jobs_;
  FarmQueue queue_;
  store::JobQueue local_;
  store::JobQueue mirror_;

  std::mutex pool_mu_;
  std::vector<std::unique_ptr<RedisClient>> pool_;

  mutable std::mutex claims_mu_;
  std::map<std::string, Claim> claims_;
  std::set<std::string> lost_;

  std::mutex watch_mu_;
  std::set<std::string> watched_;

  std::mutex wake_mu_;
  std::condition_variable_any wake_;
  uint64_t wakes_ = 0;

  std::mutex reach_mu_;
  bool reachable_ = true;

  std::atomic<uint64_t> round_trips_{0};

  std::jthread subscriber_;
  std::jthread keeper_;
};

}  // namespace kiln::cluster
