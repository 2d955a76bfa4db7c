// kilnd's farm mode in one call (docs/SCALING.md): the job records and the queue of a node of the farm, which the
// service uses in place of SQLite and the in-memory queue. Both share the node (its connections and threads),
// which stops when the last of them goes.
#pragma once

#include <memory>

#include "daemon/cluster/farm_node.h"
#include "daemon/store/job_queue.h"
#include "daemon/store/job_records.h"

namespace kiln::cluster {

struct Farm {
  std::unique_ptr<store::JobRecords> records;
  std::unique_ptr<store::WorkQueue> queue;
  std::shared_ptr<FarmNode> node;  // for its figures (round trips); the service needs only the two above
};

// Connects to the farm's Redis (RedisError, naming it, if it cannot) and starts the node's threads.
Farm join_farm(FarmConfig config);

}  // namespace kiln::cluster
