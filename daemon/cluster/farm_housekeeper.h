// A farm node's retention thread (farm_retention.h): a pass every `period`, and soon after a submit when the store
// has a limit. Every node runs one; the lock in Redis lets one pass run at a time for the farm.
#pragma once

#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <stop_token>
#include <string>
#include <thread>

#include "daemon/cluster/farm_node.h"
#include "daemon/cluster/farm_retention.h"

namespace kiln::cluster {

class FarmHousekeeper {
 public:
  FarmHousekeeper(std::shared_ptr<FarmNode> node, store::BlobStore& blobs, FarmRetentionOptions options,
                  std::chrono::milliseconds period);
  ~FarmHousekeeper();  // stops the thread (a pass in progress ends first)
  FarmHousekeeper(const FarmHousekeeper&) = delete;
  FarmHousekeeper& operator=(const FarmHousekeeper&) = delete;

  // A job was submitted: with a store limit, run a pass soon (at most one a second).
  void poke();
  // An upload completed (FarmRetention::stored). Redis out of reach is logged, not thrown: the upload is stored.
  void stored(const std::string& digest);

 private:
  void loop(std::stop_token stop);
  void pass();

  std::shared_ptr<FarmNode> node_;
  FarmRetention retention_;
  std::chrono::milliseconds period_;
  std::mutex mu_;
  std::condition_variable_any wake_;
  bool poked_ = false;
  bool over_limit_ = false;  // the last pass could not bring the store under its limit (the thread's own)
  std::jthread thread_;
};

}  // namespace kiln::cluster
