#include "daemon/cluster/farm.h"

#include "daemon/cluster/farm_records.h"
#include "daemon/cluster/farm_work_queue.h"

namespace kiln::cluster {

Farm join_farm(FarmConfig config) {
  auto node = std::make_shared<FarmNode>(std::move(config));
  Farm farm;
  farm.records = std::make_unique<FarmRecords>(node);
  farm.queue = std::make_unique<FarmWorkQueue>(node);
  farm.node = node;
  return farm;
}

}  // namespace kiln::cluster
