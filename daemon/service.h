// What kilnd does with each request, independent of sockets: authentication, blobs, jobs, results, status.
// Sessions (session.cpp) feed it decoded requests and write back what it answers; workers (workers.cpp) run the
// bakes. Everything here is thread-safe.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <thread>

#include "daemon/auth.h"
#include "daemon/config.h"
#include "daemon/hello_throttle.h"
#include "daemon/memory_budget.h"
#include "daemon/store/job_queue.h"

namespace kiln::v1 {
class JobResult;
class Request;
class Response;
}  // namespace kiln::v1

namespace kiln::store {
class BlobStore;
struct BlobStoreOptions;
class JobDb;
class JobRecords;
}  // namespace kiln::store

namespace kiln::cluster {
class FarmNode;
class FarmHousekeeper;
}  // namespace kiln::cluster

namespace kiln::daemon {

class Workers;

extern const char* const kServerVersion;

// What the service knows of one connection.
struct SessionInfo {
  bool unix_socket = false;    // the socket's permissions already decided who may connect
  bool authenticated = false;  // a Hello was accepted
  std::string peer;            // for logs
  std::string address;         // the peer's IP address on TCP (without the port); empty on the Unix socket
  uint64_t id = 0;             // for logs
};

class Service {
 public:
  // Opens the store under config.store (creating it), recovers the jobs a previous run left queued or running, and
  // starts the workers. `tokens` may be empty only when the service is reached through a Unix socket alone.
  Service(const Config& config, TokenSet tokens);
  ~Service();
  Service(const Service&) = delete;
  Service& operator=(const Service&) = delete;

  // Answers one request. For a Watch the first event is the answer, and `on_event` receives the later ones (from any
  // thread) while `watch` is kept; the session calls watch->ready() when it has written the previous event.
  void handle(SessionInfo& session, const v1::Request& request, v1::Response& response,
              const std::function<void(const v1::Response&)>& on_event, store::Subscription* watch);

  // A response for a connection-level problem (id 0), e.g. a frame too large or a deadline missed.
  static void connection_error(v1::Response& response, int code, const std::string& message);

  // Stops accepting submits, lets running jobs finish for `grace`, then cancels them back into the queue (they run
  // again at the next start), and stops the workers.
  void shutdown(std::chrono::duration<double> grace);
  bool shutting_down() const { return shutting_down_; }

  // A Hello failed on this connection, which the session closes after answering. Returns how long to wait before
  // the answer: growing with the recent failures from the same address, so tokens cannot be guessed at speed.
  std::chrono::milliseconds hello_failed(const SessionInfo& session);

  void connection_opened() { ++connections_; }
  void connection_closed() { --connections_; }

  const Config& config() const { return config_; }

 private:
  void hello(SessionInfo& s, const v1::Request& req, v1::Response& resp);
  void blob_query(const v1::Request& req, v1::Response& resp);
  void blob_put(const v1::Request& req, v1::Response& resp);
  void submit(const SessionInfo& s, const v1::Request& req, v1::Response& resp);
  void watch(const v1::Request& req, v1::Response& resp, const std::function<void(const v1::Response&)>& on_event,
             store::Subscription* watch);
  void cancel(const v1::Request& req, v1::Response& resp);
  void result(const v1::Request& req, v1::Response& resp);
  void fetch(const v1::Request& req, v1::Response& resp);
  void status(v1::Response& resp);
  void list_jobs(const v1::Request& req, v1::Response& resp);
  // True if every output of a cached result is still in the store; otherwise marks the results that refer to the
  // missing one as evicted (they leave the cache) and returns false.
  bool outputs_stored(const v1::JobResult& result, const std::string& job_id);
  // Evicts least recently used results past the store limit (under the submit lock); in a farm, asks for a pass of
  // the farm's retention (cluster::FarmHousekeeper), which runs on one node at a time.
  void enforce_retention();
  // The last resort of a shutdown: re-queues in the database the jobs whose bakes did not stop at their cancel,
  // and exits the process without joining their threads.
  [[noreturn]] void abandon_running_jobs();
  // One kilnd alone: the jobs the previous run left queued or running are queued again.
  void recover_local_jobs();
  // Farm mode (config.cluster): the records and queue in Redis, this node's own temporary files in the shared store.
  void join_farm(store::BlobStoreOptions& blob_options);
  // Farm mode: the node's retention thread (record expiry, the shared store's limit), once the store is open.
  void start_farm_retention();
  // Deletes partial uploads older than partial_upload_max_age_seconds, logging what it removed.
  void remove_abandoned_uploads(const char* when);
  // The sweeper thread: remove_abandoned_uploads every quarter of the age (1 s to 1 h) until shutdown.
  void sweep_uploads();

  Config config_;
  TokenSet tokens_;
  std::unique_ptr<store::BlobStore> blobs_;
  // One node's SQLite store, or nothing in a farm (whose records are in Redis): retention and recovery use it.
  store::JobDb* local_db_ = nullptr;
  std::unique_ptr<store::JobRecords> db_;
  std::unique_ptr<store::WorkQueue> queue_;
  std::unique_ptr<MemoryBudget> memory_;  // before the workers, which hold reservations of it
  std::unique_ptr<Workers> workers_;
  std::mutex submit_mutex_;  // submits and retention do not interleave (see store::enforce_retention)
  std::atomic<bool> shutting_down_{false};
  std::atomic<int> connections_{0};
  HelloThrottle hello_throttle_;
  std::mutex sweep_mutex_;
  std::condition_variable sweep_wake_;
  bool sweep_stop_ = false;
  std::thread sweeper_;
  std::chrono::steady_clock::time_point started_ = std::chrono::steady_clock::now();
  std::shared_ptr<cluster::FarmNode> farm_node_;  // farm mode only
  std::unique_ptr<cluster::FarmHousekeeper> housekeeper_;  // farm mode only; stopped before the store closes
};

}  // namespace kiln::daemon
