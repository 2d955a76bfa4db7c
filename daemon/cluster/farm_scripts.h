// The farm's Lua scripts (docs/SCALING.md, "The queue"): each changes a job's state, its queue entry, the counts and
// the events in one atomic step on the Redis server. ARGV[1] is always the key prefix ("kiln:").
#pragma once

#include <string>

namespace kiln::cluster::scripts {

// ARGV: prefix, id, name, type, spec, spec_key, priority, idempotency key or "", inputs, now, cache source or "",
// cached result, cached outputs, max queued (0: no limit), seconds an eviction's tombstone refuses an input.
// Publishes the priority on PREFIXqueued (idle workers wake). A cache source evicted meanwhile: the job is queued.
// Returns {1, id} (created), {0, id} (the key's earlier job), {-1, queued} (the queue is full); an error reply
// starting KILN_ALREADY_EXISTS for a key used with another spec, KILN_EVICTED DIGEST for an input evicted just now.
const std::string& insert();

// ARGV: prefix, consumer, lease ms, now, max_crash_restarts, node.
// Returns {level, entry, id, HGETALL of the job} for the job this consumer now runs, or nil.
const std::string& claim();

// ARGV: prefix, consumer, level, entry, id. Returns {1, cancel asked (0/1)} if the lease was renewed, {0, 0} if the
// entry is no longer this consumer's.
const std::string& renew();

// ARGV: prefix, id, level, entry, outcome (succeeded, failed or cancelled), now, result or error, outputs.
// Returns {1, outcome} (committed) or {0, the state it already had} (a duplicate, counted and discarded).
const std::string& commit();

// ARGV: prefix, id, level, entry, consumer. Hands a running job back to the queue: returns 1, or 0 if it was not
// this consumer's to hand back.
const std::string& requeue();

// ARGV: prefix, id, now. Returns "removed_from_queue", "signalled" or "unknown" (finished or no such job).
const std::string& cancel();

// ARGV: prefix, now, digest… Marks evicted every succeeded result that refers to one of the digests (and drops it
// from the result cache). Returns how many.
const std::string& evict_results();

// ARGV: prefix, id, now. Marks the job's result and its outputs used now. Returns 1, or 0 for an unknown job.
const std::string& touch();

// ARGV: prefix, lock token, now, cutoff, lock lease ms, digest. Returns {1, results evicted} when the blob may be
// removed now (its results left the cache), {0, 0} when it is pinned or used after the cutoff, {-1, 0} when this
// node no longer holds the retention lock.
const std::string& evict_blob();

// ARGV: prefix, cutoff, limit. Deletes up to `limit` finished jobs last used before the cutoff. Returns how many.
const std::string& expire_jobs();

}  // namespace kiln::cluster::scripts
