#include "daemon/cluster/farm_jobs.h"

#include <algorithm>

#include "daemon/cluster/farm_job_hash.h"
#include "daemon/cluster/farm_scripts.h"

namespace kiln::cluster {

namespace {

void check_key_part(std::string_view part, const char* what) {
  if (part.empty() || part.size() > kMaxKeyPartBytes) {
    throw store::StoreError(store::StoreErrc::invalid_argument,
                            std::string(what) + " must be 1 to " + std::to_string(kMaxKeyPartBytes) + " bytes");
  }
}

}  // namespace

std::string FarmJobs::key(std::string_view kind, std::string_view name) const {
  return prefix_ + std::string(kind) + ":" + std::string(name);
}

std::optional<store::JobRecord> FarmJobs::get_by_reply(const std::string& id, const RedisReply& hgetall) {
  if (hgetall.as_array().empty()) return std::nullopt;  // HGETALL of a missing key is an empty array
  return decode_job(id, hgetall);
}

store::InsertOutcome FarmJobs::insert(RedisClient& redis, const store::NewJob& job, uint32_t max_queued) {
  store::check_new_job(job);
  const std::string id = store::new_job_id();
  const store::CachedResult* c = job.cached ? &*job.cached : nullptr;
  RedisReply r;
  try {
    r = redis.eval(scripts::insert(), {},
                   {prefix_, id, job.name, job.type, job.spec, job.spec_key, std::to_string(job.priority),
                    job.idempotency_key.value_or(""), store::join_digests(job.input_digests),
                    encode_time(store::unix_now()), c ? c->source_job_id : "", c ? c->result : "",
                    c ? store::join_digests(c->output_digests) : "", std::to_string(max_queued),
                    std::to_string(kEvictedInputSeconds)});
  } catch (const RedisError& e) {
    const std::string what = e.what();
    if (const size_t ev = what.find("KILN_EVICTED "); ev != std::string::npos) {
      throw store::StoreError(store::StoreErrc::not_found,
                              "input blob " + what.substr(ev + 13, 64) +
                                  " was removed from the farm's store by its retention limit just now; upload it "
                                  "again and resubmit the job");
    }
    const size_t at = what.find("KILN_ALREADY_EXISTS ");
    if (at == std::string::npos) throw;
    throw store::StoreError(store::StoreErrc::already_exists,
                            "idempotency key '" + *job.idempotency_key + "' was already used for job " +
                                what.substr(at + 20, 32) + " with a different spec; use a new key for a different job");
  }
  const auto& parts = r.as_array();
  const long long status = parts.at(0).as_integer();
  if (status < 0) {
    throw store::StoreError(store::StoreErrc::resource_exhausted, "the farm's queue holds " + parts.at(1).as_string() +
                                                                      " jobs, its limit; submit again later");
  }
  const std::string& found = parts.at(1).as_string();
  auto record = get(redis, found);
  if (!record)
    throw store::StoreError(store::StoreErrc::not_found, "job " + found + " vanished right after its insert");
  return {std::move(*record), status == 1};
}

std::optional<store::JobRecord> FarmJobs::get(RedisClient& redis, std::string_view id) {
  check_key_part(id, "a job id");
  return get_by_reply(std::string(id), redis.read({"HGETALL", key("job", id)}));
}

std::optional<store::JobRecord> FarmJobs::find_by_idempotency_key(RedisClient& redis, std::string_view idem) {
  check_key_part(idem, "an idempotency key");
  const RedisReply id = redis.read({"GET", key("idem", idem)});
  if (id.is_nil()) return std::nullopt;
  return get(redis, id.as_string());
}

std::optional<store::JobRecord> FarmJobs::find_succeeded_by_spec_key(RedisClient& redis, std::string_view spec_key) {
  check_key_part(spec_key, "a cache key");
  const RedisReply id = redis.read({"GET", key("cache", spec_key)});
  if (id.is_nil()) return std::nullopt;
  auto record = get(redis, id.as_string());
  if (!record || record->state != store::JobState::succeeded || record->evicted) return std::nullopt;
  return record;
}

std::vector<store::JobRecord> FarmJobs::list(RedisClient& redis, size_t limit, std::optional<store::JobState> state,
                                             std::optional<int64_t> before_seq) {
  const std::string set = state ? key("jobs", store::to_string(*state)) : prefix_ + "jobs";
  const std::string max = before_seq ? "(" + std::to_string(*before_seq) : "+inf";
  const RedisReply ids = redis.read({"ZREVRANGEBYSCORE", set, max, "-inf", "LIMIT", "0", std::to_string(limit)});
  std::vector<std::vector<std::string>> reads;
  for (const RedisReply& id : ids.as_array()) reads.push_back({"HGETALL", key("job", id.as_string())});
  if (reads.empty()) return {};
  const std::vector<RedisReply> hashes = redis.pipeline(reads);  // one round trip for the whole page
  std::vector<store::JobRecord> out;
  for (size_t i = 0; i < hashes.size(); ++i) {
    auto r = get_by_reply(ids.as_array()[i].as_string(), hashes[i]);
    if (!r) continue;  // removed between the two reads
    r->spec.clear();
    r->result.clear();
    out.push_back(std::move(*r));
  }
  return out;
}

FarmCounts FarmJobs::counts(RedisClient& redis) {
  const RedisReply all = redis.read({"HGETALL", prefix_ + "counts"});
  FarmCounts c;
  const auto& items = all.as_array();
  for (size_t i = 0; i + 1 < items.size(); i += 2) {
    const std::string& name = items[i].as_string();
    const uint64_t n = static_cast<uint64_t>(std::max(0LL, std::stoll(items[i + 1].as_string())));
    if (name == "queued") c.jobs.queued = n;
    if (name == "running") c.jobs.running = n;
    if (name == "succeeded") c.jobs.succeeded = n;
    if (name == "failed") c.jobs.failed = n;
    if (name == "cancelled") c.jobs.cancelled = n;
    if (name == "cache_hits") c.jobs.cache_hits = n;
    if (name == "duplicates") c.duplicates = n;
  }
  return c;
}

bool FarmJobs::touch(RedisClient& redis, std::string_view id, std::optional<double> when) {
  check_key_part(id, "a job id");
  // HSET on a missing hash would create it: the existence check and the write go in one script.
  const RedisReply r =
      redis.eval(scripts::touch(), {}, {prefix_, std::string(id), encode_time(when.value_or(store::unix_now()))});
  return r.as_integer() == 1;
}

store::CancelOutcome FarmJobs::cancel(RedisClient& redis, std::string_view id) {
  check_key_part(id, "a job id");
  const std::string out =
      redis.eval(scripts::cancel(), {}, {prefix_, std::string(id), encode_time(store::unix_now())}).as_string();
  if (out == "removed_from_queue") return store::CancelOutcome::removed_from_queue;
  if (out == "signalled") return store::CancelOutcome::signalled;
  return store::CancelOutcome::unknown;
}

size_t FarmJobs::mark_results_evicted(RedisClient& redis, const std::vector<std::string>& digests) {
  std::vector<std::string> args{prefix_, encode_time(store::unix_now())};
  args.insert(args.end(), digests.begin(), digests.end());
  return static_cast<size_t>(redis.eval(scripts::evict_results(), {}, args).as_integer());
}

std::optional<store::Progress> FarmJobs::latest(RedisClient& redis, std::string_view id) {
  check_key_part(id, "a job id");
  const RedisReply r = redis.read({"HGET", key("job", id), "progress"});
  if (r.is_nil()) return std::nullopt;
  return decode_progress(r.as_string());
}

}  // namespace kiln::cluster
