#include "daemon/cluster/farm_queue.h"

#include "daemon/cluster/farm_job_hash.h"
#include "daemon/cluster/farm_scripts.h"

namespace kiln::cluster {

std::optional<Claim> FarmQueue::claim(RedisClient& redis, int index) {
  const std::string consumer = options_.node + "/" + std::to_string(index);
  const RedisReply r =
      redis.eval(scripts::claim(), {},
                 {options_.prefix, consumer, std::to_string(options_.lease.count()), encode_time(store::unix_now()),
                  std::to_string(options_.max_crash_restarts), options_.node});
  if (r.is_nil()) return std::nullopt;
  const auto& parts = r.as_array();
  if (parts.size() != 4) throw RedisError(RedisErrc::protocol, "the claim script answered with a malformed reply");
  Claim c;
  c.consumer = consumer;
  c.level = parts[0].as_string();
  c.entry = parts[1].as_string();
  c.job = decode_job(parts[2].as_string(), parts[3]);
  return c;
}

LeaseState FarmQueue::renew(RedisClient& redis, const Claim& claim) {
  const RedisReply r =
      redis.eval(scripts::renew(), {}, {options_.prefix, claim.consumer, claim.level, claim.entry, claim.job.id});
  const auto& parts = r.as_array();
  return LeaseState{parts.at(0).as_integer() == 1, parts.at(1).as_integer() == 1};
}

CommitOutcome FarmQueue::commit(RedisClient& redis, const Claim& claim, const char* outcome, const std::string& text,
                                const std::string& outputs) {
  const RedisReply r = redis.eval(scripts::commit(), {},
                                  {options_.prefix, claim.job.id, claim.level, claim.entry, outcome,
                                   encode_time(store::unix_now()), text, outputs});
  return r.as_array().at(0).as_integer() == 1 ? CommitOutcome::committed : CommitOutcome::duplicate;
}

CommitOutcome FarmQueue::commit_success(RedisClient& redis, const Claim& claim, const std::string& result,
                                        const std::vector<std::string>& output_digests) {
  return commit(redis, claim, "succeeded", result, store::join_digests(output_digests));
}

CommitOutcome FarmQueue::commit_failure(RedisClient& redis, const Claim& claim, const std::string& error) {
  return commit(redis, claim, "failed", error, "");
}

CommitOutcome FarmQueue::commit_cancelled(RedisClient& redis, const Claim& claim) {
  return commit(redis, claim, "cancelled", "", "");
}

bool FarmQueue::requeue(RedisClient& redis, const Claim& claim) {
  return redis.eval(scripts::requeue(), {}, {options_.prefix, claim.job.id, claim.level, claim.entry, claim.consumer})
             .as_integer() == 1;
}

void FarmQueue::publish(RedisClient& redis, const std::string& id, const store::Progress& progress) {
  const std::string payload = encode_progress(progress);
  redis.pipeline({{"HSET", options_.prefix + "job:" + id, "progress", payload},
                  {"PUBLISH", options_.prefix + "ev:" + id, payload}});
}

}  // namespace kiln::cluster
