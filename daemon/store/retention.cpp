#include "daemon/store/retention.h"

#include <unordered_set>

#include "daemon/store/job_db.h"

namespace kiln::store {

RetentionReport enforce_retention(JobDb& db, BlobStore& blobs, uint64_t limit_bytes) {
  RetentionReport r;
  r.blobs = blobs.evict_to(limit_bytes, db.pinned_digests(), db.blob_last_used());
  std::unordered_set<std::string> removed;
  for (const auto& id : r.blobs.removed) removed.insert(id.digest);
  r.results_evicted = db.mark_results_evicted(removed);
  return r;
}

}  // namespace kiln::store
