// The store's retention limit, which spans both stores: blobs are evicted by how recently the jobs that refer to
// them were used, and the results that lose a blob are marked evicted in the job database.
#pragma once

#include <cstddef>
#include <cstdint>

#include "daemon/store/blob_store.h"

namespace kiln::store {

class JobDb;

struct RetentionReport {
  EvictionReport blobs;
  size_t results_evicted = 0;
};

// Brings the blobs under limit_bytes: pins what queued and running jobs read, evicts the least recently used other
// blobs (their last use taken from the jobs that refer to them, else the file's time), then marks the results that
// lost a blob as evicted. The daemon must not insert a job between this call's start and end (run it under the
// same lock or strand as submit), or a blob the new job needs could be chosen for eviction.
RetentionReport enforce_retention(JobDb& db, BlobStore& blobs, uint64_t limit_bytes);

}  // namespace kiln::store
