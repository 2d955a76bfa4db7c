#include "daemon/cluster/farm_retention.h"

#include <cstdio>
#include <random>
#include <unordered_map>
#include <unordered_set>

#include "daemon/cluster/farm_job_hash.h"
#include "daemon/cluster/farm_jobs.h"
#include "daemon/cluster/farm_scripts.h"
#include "daemon/store/job_db.h"

namespace kiln::cluster {

namespace {

// Records deleted per script call: a call holds Redis for about a millisecond per hundred.
constexpr int kExpireBatch = 500;

std::string random_hex() {
  std::random_device rd;
  const uint64_t v = (uint64_t{rd()} << 32) ^ rd();
  char out[17];
  std::snprintf(out, sizeof out, "%016llx", static_cast<unsigned long long>(v));
  return out;
}

}  // namespace

FarmRetention::FarmRetention(FarmRetentionOptions options, store::BlobStore& blobs)
    : options_(std::move(options)), blobs_(blobs), token_(options_.node + "/" + random_hex()) {}

bool FarmRetention::lock(RedisClient& redis) {
  const RedisReply r = redis.command(
      {"SET", options_.prefix + "retention", token_, "NX", "PX", std::to_string(options_.lock_lease.count())});
  return !r.is_nil();
}

void FarmRetention::unlock(RedisClient& redis) {
  redis.eval("if redis.call('GET', KEYS[1]) == ARGV[1] then return redis.call('DEL', KEYS[1]) end return 0",
             {options_.prefix + "retention"}, {token_});
}

FarmRetentionReport FarmRetention::run(RedisClient& redis) {
  FarmRetentionReport report;
  if (!lock(redis)) return report;
  report.ran = true;
  try {
    const double now = store::unix_now();
    if (options_.job_retention_seconds > 0) report.jobs_expired = expire_jobs(redis, now - options_.job_retention_seconds);
    if (options_.store_limit_bytes > 0) report.blobs = evict(redis, report.results_evicted);
  } catch (...) {
    unlock(redis);  // may fail too (Redis gone): the lock's lease then frees it
    throw;
  }
  unlock(redis);
  return report;
}

size_t FarmRetention::expire_jobs(RedisClient& redis, double cutoff) {
  size_t total = 0;
  for (;;) {
    const long long n =
        redis.eval(scripts::expire_jobs(), {}, {options_.prefix, encode_time(cutoff), std::to_string(kExpireBatch)})
            .as_integer();
    total += static_cast<size_t>(n);
    if (n < kExpireBatch) return total;
  }
}

void FarmRetention::stored(RedisClient& redis, const std::string& digest) {
  const std::string now = encode_time(store::unix_now());
  redis.pipeline({{"ZADD", options_.prefix + "blob_used", "GT", now, digest},
                  {"ZREM", options_.prefix + "evicting", digest}});
}

store::EvictionReport FarmRetention::evict(RedisClient& redis, size_t& results_evicted) {
  const double now = store::unix_now();
  const double cutoff = now - options_.eviction_grace_seconds;
  // Tombstones older than any submit in flight refuse nothing any more.
  redis.command({"ZREMRANGEBYSCORE", options_.prefix + "evicting", "-inf", encode_time(now - kEvictedInputSeconds)});
  std::unordered_set<std::string> pinned;
  const RedisReply pins = redis.command({"HKEYS", options_.prefix + "pins"});
  for (const RedisReply& d : pins.as_array()) pinned.insert(d.as_string());
  std::unordered_map<std::string, double> last_used;
  const RedisReply reply = redis.command({"ZRANGE", options_.prefix + "blob_used", "0", "-1", "WITHSCORES"});
  const auto& scored = reply.as_array();
  for (size_t i = 0; i + 1 < scored.size(); i += 2) last_used[scored[i].as_string()] = std::stod(scored[i + 1].as_string());
  bool lost = false;
  return blobs_.evict_to(options_.store_limit_bytes, pinned, last_used,
                         [&](const store::BlobId& id, double used) {
                           return confirm(redis, id, used, cutoff, lost, results_evicted);
                         });
}

bool FarmRetention::confirm(RedisClient& redis, const store::BlobId& id, double last_used, double cutoff, bool& lost,
                            size_t& results_evicted) {
  // Lost lock: another node runs the pass now; used within the grace (by Redis's record or the file's time): kept.
  if (lost || last_used > cutoff) return false;
  const RedisReply r = redis.eval(scripts::evict_blob(), {},
                                  {options_.prefix, token_, encode_time(store::unix_now()), encode_time(cutoff),
                                   std::to_string(options_.lock_lease.count()), id.digest});
  const long long verdict = r.as_array().at(0).as_integer();
  if (verdict < 0) lost = true;
  if (verdict <= 0) return false;
  results_evicted += static_cast<size_t>(r.as_array().at(1).as_integer());
  return true;
}

}  // namespace kiln::cluster
