#include "daemon/service.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include <unistd.h>

#include "bakers/lightmap/memory_estimate.h"
#include "daemon/cluster/farm.h"
#include "daemon/cluster/farm_housekeeper.h"
#include "daemon/log.h"
#include "daemon/store/blob_store.h"
#include "daemon/store/job_db.h"
#include "daemon/store/retention.h"
#include "daemon/translate.h"
#include "daemon/workers.h"
#include "proto/bounds.h"
#include "proto/digest.h"
#include "proto/framing.h"
#include "proto/kiln.pb.h"

namespace kiln::daemon {

const char* const kServerVersion = "kilnd 0.1.0";

namespace {

constexpr std::size_t kMaxTokenBytes = 256;
constexpr std::size_t kMaxClientNameBytes = 256;
constexpr std::size_t kMaxIdempotencyKeyBytes = 128;
constexpr std::size_t kMaxJobIdBytes = 64;
constexpr uint32_t kMaxQueryDigests = 1024;

// A request failed: the error goes into the response with its code, message and field.
struct Failure {
  v1::Error::Code code;
  std::string message;
  std::string field;
};

[[noreturn]] void fail(v1::Error::Code code, std::string message, std::string field = {}) {
  throw Failure{code, std::move(message), std::move(field)};
}

v1::Error::Code to_code(store::StoreErrc e) {
  switch (e) {
    case store::StoreErrc::invalid_argument:
      return v1::Error::INVALID_ARGUMENT;
    case store::StoreErrc::not_found:
      return v1::Error::NOT_FOUND;
    case store::StoreErrc::already_exists:
      return v1::Error::INVALID_ARGUMENT;
    case store::StoreErrc::failed_precondition:
      return v1::Error::FAILED_PRECONDITION;
    case store::StoreErrc::out_of_range:
      return v1::Error::INVALID_ARGUMENT;
    case store::StoreErrc::data_loss:
      return v1::Error::DATA_LOSS;
    case store::StoreErrc::resource_exhausted:
      return v1::Error::RESOURCE_EXHAUSTED;
    case store::StoreErrc::io:
      return v1::Error::INTERNAL;
    case store::StoreErrc::unavailable:
      return v1::Error::UNAVAILABLE;
  }
  return v1::Error::INTERNAL;
}

v1::JobState to_proto(store::JobState s) {
  switch (s) {
    case store::JobState::queued:
      return v1::JOB_STATE_QUEUED;
    case store::JobState::running:
      return v1::JOB_STATE_RUNNING;
    case store::JobState::succeeded:
      return v1::JOB_STATE_SUCCEEDED;
    case store::JobState::failed:
      return v1::JOB_STATE_FAILED;
    case store::JobState::cancelled:
      return v1::JOB_STATE_CANCELLED;
  }
  return v1::JOB_STATE_UNSPECIFIED;
}

// A digest from the wire, checked: 64 lowercase hex digits and a size within the limit.
store::BlobId checked_digest(const v1::Digest& d, const std::string& field, uint64_t max_size) {
  if (!proto::is_valid_sha256_hex(d.sha256())) {
    fail(v1::Error::INVALID_ARGUMENT, "must be 64 lowercase hex digits", field + ".sha256");
  }
  if (d.size() > max_size) {
    fail(v1::Error::RESOURCE_EXHAUSTED,
         "blob of " + std::to_string(d.size()) + " bytes exceeds the limit of " + std::to_string(max_size),
         field + ".size");
  }
  return store::BlobId{d.sha256(), d.size()};
}

std::string checked_job_id(const std::string& id, const std::string& field) {
  if (id.empty() || id.size() > kMaxJobIdBytes) {
    fail(v1::Error::INVALID_ARGUMENT, "a job id of 1 to 64 characters is required", field);
  }
  return id;
}

v1::JobEvent event_of(const std::string& id, const store::Progress& p) {
  v1::JobEvent e;
  e.set_job_id(id);
  e.set_state(to_proto(p.state));
  e.set_fraction(p.fraction);
  e.set_eta_seconds(p.eta_seconds.value_or(-1));
  e.set_samples(p.samples);
  e.set_error_estimate(p.error_estimate.value_or(-1));
  e.set_message(p.message);
  e.set_final(store::is_terminal(p.state));
  return e;
}

v1::JobEvent event_of(const store::JobRecord& r) {
  store::Progress p;
  p.state = r.state;
  p.fraction = r.state == store::JobState::succeeded ? 1.0 : 0.0;
  p.message = r.error;
  // A finished job's cost comes from its report (for a cache hit, the original bake's).
  v1::JobResult result;
  if (r.state == store::JobState::succeeded && result.ParseFromString(r.result)) {
    p.samples = result.report().samples();
    p.error_estimate = result.report().error_estimate();
    if (result.report().cache_hit()) p.message = "answered from the result cache";
  }
  v1::JobEvent e = event_of(r.id, p);
  if (r.started && r.finished) e.set_elapsed_seconds(*r.finished - *r.started);
  return e;
}

}  // namespace

Service::Service(const Config& config, TokenSet tokens) : config_(config), tokens_(std::move(tokens)) {
  std::filesystem::create_directories(config_.store);
  store::BlobStoreOptions blob_options;
  blob_options.max_blob_size = config_.max_blob_bytes;
  if (config_.cluster.empty()) {
    // The database first: its lock keeps a second kilnd out of the store before the blob store cleans its tmp/.
    store::JobDbOptions db_options;
    db_options.max_crash_restarts = static_cast<int>(config_.max_crash_restarts);
    auto db = std::make_unique<store::JobDb>(std::filesystem::path(config_.store) / "jobs.sqlite", db_options);
    local_db_ = db.get();
    db_ = std::move(db);
  } else {
    join_farm(blob_options);
  }
  blobs_ = std::make_unique<store::BlobStore>(std::filesystem::path(config_.store), blob_options);
  keep_baker_tables_in((std::filesystem::path(config_.store) / "tables").string());
  remove_abandoned_uploads("at start");
  if (local_db_) recover_local_jobs();
  if (farm_node_) start_farm_retention();
  if (config_.memory_limit_bytes == 0) config_.memory_limit_bytes = default_memory_limit();
  memory_ = std::make_unique<MemoryBudget>(config_.memory_limit_bytes);
  log_line("start", "memory limit for the running jobs: " + lightmap::format_bytes(config_.memory_limit_bytes));
  workers_ = std::make_unique<Workers>(config_, *db_, *blobs_, *queue_, *memory_);
  workers_->start();
  sweeper_ = std::thread([this] { sweep_uploads(); });
}

void Service::recover_local_jobs() {
  queue_ = std::make_unique<store::JobQueue>();
  const store::Recovery recovery = local_db_->recover_unfinished();
  for (const store::JobRecord& r : recovery.queued) queue_->push(r.id, r.priority, r.seq);
  for (const store::JobRecord& r : recovery.gave_up) log_line("job " + r.id, "not run again: " + r.error);
  if (!recovery.queued.empty()) {
    log_line("store " + config_.store,
             std::to_string(recovery.queued.size()) + " job(s) left unfinished by the previous run are queued again");
  }
}

void Service::join_farm(store::BlobStoreOptions& blob_options) {
  if (config_.node_name.empty()) {
    char host[256] = {};
    ::gethostname(host, sizeof host - 1);
    config_.node_name = std::string(host) + "-" + std::to_string(::getpid());
  }
  cluster::FarmConfig farm;
  farm.url = config_.cluster;
  farm.password = read_cluster_password(config_);
  farm.node = config_.node_name;
  farm.lease = std::chrono::milliseconds(std::llround(config_.cluster_lease_seconds * 1000));
  farm.max_crash_restarts = static_cast<int>(config_.max_crash_restarts);
  farm.max_queued_jobs = config_.max_queued_jobs;
  farm.log = log_line;
  cluster::Farm joined = cluster::join_farm(std::move(farm));
  db_ = std::move(joined.records);
  queue_ = std::move(joined.queue);
  farm_node_ = std::move(joined.node);
  // The nodes share the store: each writes, and cleans at start, only its own temporary files.
  blob_options.tmp_subdir = std::filesystem::path("tmp") / config_.node_name;
  log_line("farm " + config_.cluster, "joined as node " + config_.node_name + " with " +
                                          std::to_string(config_.workers) + " worker(s), store " + config_.store);
}

void Service::start_farm_retention() {
  cluster::FarmRetentionOptions o;
  o.node = config_.node_name;
  o.store_limit_bytes = config_.store_limit_bytes;
  o.eviction_grace_seconds = config_.cluster_eviction_grace_seconds;
  o.job_retention_seconds = config_.cluster_job_retention_seconds;
  // Expiry needs no haste (records are kept for days); a store limit is also asked for after each submit.
  constexpr std::chrono::seconds kPeriod{30};
  housekeeper_ = std::make_unique<cluster::FarmHousekeeper>(farm_node_, *blobs_, o, kPeriod);
}

void Service::remove_abandoned_uploads(const char* when) {
  const auto max_age = std::chrono::seconds(std::llround(config_.partial_upload_max_age_seconds));
  try {
    const size_t removed = blobs_->remove_partials_older_than(max_age);
    if (removed > 0) {
      log_line("store " + config_.store, std::string(when) + ": deleted " + std::to_string(removed) +
                                             " partial upload(s) untouched for over " +
                                             std::to_string(max_age.count()) + " s (partial_upload_max_age_seconds)");
    }
  } catch (const std::exception& e) {
    log_line("store " + config_.store, std::string("cannot delete abandoned partial uploads: ") + e.what());
  }
}

void Service::sweep_uploads() {
  const double quarter = std::clamp(config_.partial_upload_max_age_seconds / 4, 1.0, 3600.0);
  const auto period = std::chrono::duration<double>(quarter);
  std::unique_lock lock(sweep_mutex_);
  while (!sweep_wake_.wait_for(lock, period, [this] { return sweep_stop_; })) {
    lock.unlock();
    remove_abandoned_uploads("sweep");
    lock.lock();
  }
}

Service::~Service() { shutdown(std::chrono::seconds(0)); }

void Service::shutdown(std::chrono::duration<double> grace) {
  if (shutting_down_.exchange(true)) return;
  // Stop handing out jobs; those still waiting stay queued in the database.
  queue_->shutdown();
  const auto deadline = std::chrono::steady_clock::now() + grace;
  while (queue_->running() > 0 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  if (queue_->running() > 0) {
    log_line("shutdown", std::to_string(queue_->running()) +
                             " running job(s) did not finish within the grace "
                             "period; they are re-queued for the next start");
    workers_->requeue_cancelled();
    for (const std::string& id : queue_->running_ids()) {
      if (auto flag = queue_->cancel_flag(id)) *flag = true;
    }
    // The bakers poll their cancel flags often (the lightmap bake within a fraction of a second in every stage);
    // should one not have stopped after kStopSeconds, its job is handed back to the queue in the database and kilnd
    // exits without it, so that a shutdown never waits past its grace for more than that.
    constexpr double kStopSeconds = 2;
    const auto stop_deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(kStopSeconds);
    while (queue_->running() > 0 && std::chrono::steady_clock::now() < stop_deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    if (queue_->running() > 0) abandon_running_jobs();
  }
  workers_->join();
  housekeeper_.reset();
  {
    std::lock_guard lock(sweep_mutex_);
    sweep_stop_ = true;
  }
  sweep_wake_.notify_all();
  if (sweeper_.joinable()) sweeper_.join();
}

void Service::abandon_running_jobs() {
  for (const std::string& id : queue_->running_ids()) {
    try {
      db_->mark_queued(id);
      log_line("job " + id, "did not stop within 2 s of its cancel; re-queued for the next start");
    } catch (const std::exception& e) {
      log_line("job " + id, std::string("did not stop within 2 s of its cancel: ") + e.what());
    }
  }
  log_line("shutdown", "done, without waiting for the jobs that did not stop");
  std::fflush(nullptr);
  std::_Exit(0);  // the worker threads still baking cannot be joined; the database is consistent as it stands
}

void Service::connection_error(v1::Response& response, int code, const std::string& message) {
  response.Clear();
  response.set_id(0);
  response.mutable_error()->set_code(static_cast<v1::Error::Code>(code));
  response.mutable_error()->set_message(message);
}

void Service::handle(SessionInfo& session, const v1::Request& req, v1::Response& resp,
                     const std::function<void(const v1::Response&)>& on_event, store::Subscription* watch_handle) {
  resp.Clear();
  resp.set_id(req.id());
  try {
    if (req.id() == 0) fail(v1::Error::INVALID_ARGUMENT, "request ids must be nonzero", "id");
    if (req.body_case() == v1::Request::kHello) return hello(session, req, resp);
    if (!session.authenticated) {
      fail(v1::Error::UNAUTHENTICATED, "send hello (with a token on TCP) before anything else");
    }
    switch (req.body_case()) {
      case v1::Request::kBlobQuery:
        return blob_query(req, resp);
      case v1::Request::kBlobPut:
        return blob_put(req, resp);
      case v1::Request::kSubmit:
        return submit(session, req, resp);
      case v1::Request::kWatch:
        return watch(req, resp, on_event, watch_handle);
      case v1::Request::kCancel:
        return cancel(req, resp);
      case v1::Request::kGetResult:
        return result(req, resp);
      case v1::Request::kFetch:
        return fetch(req, resp);
      case v1::Request::kStatus:
        return status(resp);
      case v1::Request::kListJobs:
        return list_jobs(req, resp);
      default:
        fail(v1::Error::INVALID_ARGUMENT, "empty or unknown request", "body");
    }
  } catch (const Failure& f) {
    resp.clear_body();
    resp.mutable_error()->set_code(f.code);
    resp.mutable_error()->set_message(f.message);
    resp.mutable_error()->set_field(f.field);
  } catch (const InvalidField& e) {
    resp.clear_body();
    resp.mutable_error()->set_code(v1::Error::INVALID_ARGUMENT);
    resp.mutable_error()->set_message(e.what());
    resp.mutable_error()->set_field(e.field());
  } catch (const store::StoreError& e) {
    resp.clear_body();
    resp.mutable_error()->set_code(to_code(e.code()));
    resp.mutable_error()->set_message(e.what());
  } catch (const std::exception& e) {
    log_line("connection " + std::to_string(session.id), std::string("internal error: ") + e.what());
    resp.clear_body();
    resp.mutable_error()->set_code(v1::Error::INTERNAL);
    resp.mutable_error()->set_message(std::string("internal error: ") + e.what());
  }
}

void Service::hello(SessionInfo& s, const v1::Request& req, v1::Response& resp) {
  const v1::Hello& h = req.hello();
  if (h.protocol_version() != proto::kProtocolVersion) {
    fail(v1::Error::VERSION_MISMATCH,
         "this server speaks protocol version " + std::to_string(proto::kProtocolVersion) + ", the client " +
             std::to_string(h.protocol_version()) + "; upgrade the older side",
         "protocol_version");
  }
  if (h.token().size() > kMaxTokenBytes) fail(v1::Error::INVALID_ARGUMENT, "at most 256 bytes", "token");
  if (h.client().size() > kMaxClientNameBytes) fail(v1::Error::INVALID_ARGUMENT, "at most 256 bytes", "client");
  if (!s.unix_socket && !tokens_.accepts(h.token())) {
    log_line("connection " + std::to_string(s.id) + " from " + s.peer, "refused: wrong or missing token");
    fail(v1::Error::UNAUTHENTICATED,
         "wrong or missing token: pass the token kilnd was given (--token-file or "
         "KILN_TOKEN)",
         "token");
  }
  s.authenticated = true;
  v1::HelloReply* r = resp.mutable_hello();
  r->set_protocol_version(proto::kProtocolVersion);
  r->set_server_version(kServerVersion);
  v1::Limits* l = r->mutable_limits();
  l->set_max_frame_bytes(config_.max_frame_bytes);
  l->set_max_chunk_bytes(config_.max_chunk_bytes);
  l->set_max_blob_bytes(config_.max_blob_bytes);
  l->set_max_queued_jobs(config_.max_queued_jobs);
  l->set_max_query_digests(kMaxQueryDigests);
  l->set_heartbeat_seconds(config_.heartbeat_seconds);
  l->set_frame_deadline_seconds(config_.frame_deadline_seconds);
  l->set_idle_timeout_seconds(config_.idle_timeout_seconds);
  l->set_memory_limit_bytes(config_.memory_limit_bytes);
  r->add_job_types("material");
  r->add_job_types("environment");
  r->add_job_types("lightmap");
  r->add_job_types("probes");
}

std::chrono::milliseconds Service::hello_failed(const SessionInfo& s) {
  if (s.unix_socket || s.address.empty()) return std::chrono::milliseconds(0);  // the socket's permissions decide
  return hello_throttle_.failed(s.address);
}

void Service::blob_query(const v1::Request& req, v1::Response& resp) {
  const auto& q = req.blob_query();
  if (q.digests_size() > static_cast<int>(kMaxQueryDigests)) {
    fail(v1::Error::INVALID_ARGUMENT, "at most " + std::to_string(kMaxQueryDigests) + " digests per query", "digests");
  }
  auto* reply = resp.mutable_blob_query();
  for (int i = 0; i < q.digests_size(); ++i) {
    const store::BlobId id = checked_digest(q.digests(i), "digests[" + std::to_string(i) + "]", config_.max_blob_bytes);
    if (blobs_->contains(id)) continue;
    auto* m = reply->add_missing();
    *m->mutable_digest() = q.digests(i);
    m->set_received(blobs_->received(id));
  }
}

void Service::blob_put(const v1::Request& req, v1::Response& resp) {
  const auto& p = req.blob_put();
  const store::BlobId id = checked_digest(p.digest(), "digest", config_.max_blob_bytes);
  if (p.data().size() > config_.max_chunk_bytes) {
    fail(v1::Error::INVALID_ARGUMENT, "chunks are at most " + std::to_string(config_.max_chunk_bytes) + " bytes",
         "data");
  }
  auto* reply = resp.mutable_blob_put();
  if (blobs_->contains(id)) {
    reply->set_received(id.size);
    reply->set_complete(true);
    return;
  }
  const uint64_t held = blobs_->received(id);
  if (p.offset() != held) {
    fail(v1::Error::FAILED_PRECONDITION,
         "the server holds " + std::to_string(held) + " bytes of this blob; resume from there", "offset");
  }
  if (p.offset() + p.data().size() > id.size) {
    fail(v1::Error::INVALID_ARGUMENT, "chunk runs past the blob's declared size", "data");
  }
  const uint64_t received = blobs_->append(id, p.offset(), p.data());
  reply->set_received(received);
  if (received == id.size) {
    blobs_->complete(id);  // verifies the digest; DATA_LOSS discards the partial
    if (housekeeper_) housekeeper_->stored(id.digest);  // the farm's retention sees it used, and not evicted
    reply->set_complete(true);
  }
}

void Service::submit(const SessionInfo& s, const v1::Request& req, v1::Response& resp) {
  if (shutting_down_) fail(v1::Error::UNAVAILABLE, "the server is shutting down; submit again after it restarts");
  const v1::Submit& sub = req.submit();
  if (!bounds::kPriority.contains(sub.priority())) {
    fail(v1::Error::INVALID_ARGUMENT,
         "must be in [" + std::to_string(bounds::kPriority.lo) + ", " + std::to_string(bounds::kPriority.hi) +
             "], got " + std::to_string(sub.priority()),
         "priority");
  }
  if (sub.idempotency_key().size() > kMaxIdempotencyKeyBytes) {
    fail(v1::Error::INVALID_ARGUMENT, "at most 128 bytes", "idempotency_key");
  }
  // Throws InvalidField with the path; input blobs must be stored already. Their bytes are read by the worker.
  BakeRequest bake = translate(sub.job(), blobs_.get());
  // The VDB media's grids, which only their files' structure tells (read from the store, walked, not loaded).
  size_vdb_media(bake, *blobs_);
  // Under kilnd's memory limit too: a lightmap job that would not fit whole bakes in tiles (part of its key).
  fit_memory_limit(bake, config_.memory_limit_bytes);
  const std::string key = cache_key(bake, baker_version(bake));

  std::lock_guard lock(submit_mutex_);
  store::NewJob job;
  job.name = bake.name;
  job.type = job_type(bake);
  sub.job().SerializeToString(&job.spec);
  job.spec_key = key;
  job.priority = sub.priority();
  if (!sub.idempotency_key().empty()) job.idempotency_key = sub.idempotency_key();
  // Pinned against the retention limit while the job waits or runs.
  for (const BlobRef& input : bake.inputs) job.input_digests.push_back(input.sha256);
  if (auto cached = db_->find_succeeded_by_spec_key(key)) {
    // The result cache: the new job is recorded as succeeded at once, reporting the stored outputs, provided they
    // are all still in the store (one found damaged was moved aside); otherwise the result leaves the cache and
    // the job bakes again.
    v1::JobResult result;
    if (result.ParseFromString(cached->result) && outputs_stored(result, cached->id)) {
      result.mutable_report()->set_cache_hit(true);
      store::CachedResult c;
      c.source_job_id = cached->id;
      c.output_digests = cached->output_digests;
      result.SerializeToString(&c.result);
      job.cached = std::move(c);
      const store::InsertOutcome out = db_->insert(job);
      db_->touch(cached->id);
      auto* reply = resp.mutable_submit();
      reply->set_job_id(out.job.id);
      reply->set_cache_hit(out.job.cache_source.has_value());
      reply->set_state(to_proto(out.job.state));
      log_line("job " + out.job.id, "answered from the result cache (the result of job " + cached->id + ")");
      return;
    }
  }
  // Refused up front rather than run into the kernel's OOM killer; a cached result needed no memory, so it was
  // served above whatever the job would need to bake.
  if (bake.memory_bytes > config_.memory_limit_bytes) {
    fail(v1::Error::RESOURCE_EXHAUSTED,
         "the job would need about " + lightmap::format_bytes(bake.memory_bytes) + " of memory (" + bake.memory_note +
             "), more than kilnd's memory limit of " + lightmap::format_bytes(config_.memory_limit_bytes) +
             " (--memory-limit): lower this field, or bake in several jobs",
         bake.memory_field);
  }
  if (queue_->size() >= config_.max_queued_jobs) {
    fail(v1::Error::RESOURCE_EXHAUSTED,
         "the queue holds " + std::to_string(queue_->size()) + " jobs, its limit; submit again later");
  }
  const store::InsertOutcome out = db_->insert(job);
  if (out.created) {
    queue_->push(out.job.id, out.job.priority, out.job.seq);
    log_line("job " + out.job.id, "queued (" + job.type + ", priority " + std::to_string(job.priority) +
                                      ", from connection " + std::to_string(s.id) + ")");
  }
  auto* reply = resp.mutable_submit();
  reply->set_job_id(out.job.id);
  reply->set_cache_hit(out.job.cache_source.has_value());
  reply->set_state(to_proto(out.job.state));
  if (config_.store_limit_bytes > 0) enforce_retention();
}

bool Service::outputs_stored(const v1::JobResult& result, const std::string& job_id) {
  for (const v1::Output& o : result.outputs()) {
    const store::BlobId id{o.digest().sha256(), o.digest().size()};
    if (!blobs_->contains(id)) {
      db_->mark_results_evicted({id.digest});
      log_line("job " + job_id,
               "its result leaves the cache: output " + o.name() + " (" + id.digest + ") is no longer in the store");
      return false;
    }
  }
  return true;
}

void Service::enforce_retention() {
  if (housekeeper_) {
    housekeeper_->poke();
    return;
  }
  const store::RetentionReport r = store::enforce_retention(*local_db_, *blobs_, config_.store_limit_bytes);
  if (!r.blobs.removed.empty()) {
    log_line("store " + config_.store, "evicted " + std::to_string(r.blobs.removed.size()) + " blob(s), " +
                                           std::to_string(r.blobs.bytes_freed) + " bytes, " +
                                           std::to_string(r.results_evicted) + " result(s)");
  }
}

void Service::watch(const v1::Request& req, v1::Response& resp,
                    const std::function<void(const v1::Response&)>& on_event, store::Subscription* handle) {
  const std::string id = checked_job_id(req.watch().job_id(), "job_id");
  const uint64_t request_id = req.id();
  if (handle && on_event) {
    // The first callback runs inside subscribe(): it is the answer; later ones go to on_event.
    // subscribe() runs the callback once before it returns, so `answer` is written only while this call lives.
    auto first = std::make_shared<bool>(true);
    v1::Response* answer = &resp;
    // When the job started running, for elapsed_seconds: from its record, or when the watch first sees it run.
    auto started = std::make_shared<std::optional<double>>();
    if (const auto record = db_->get(id); record && record->started) *started = *record->started;
    auto sub = queue_->subscribe(id, [first, answer, started, id, request_id, on_event](const store::Progress& p) {
      v1::Response r;
      r.set_id(request_id);
      *r.mutable_event() = event_of(id, p);
      if (p.state == store::JobState::running && !*started) *started = store::unix_now();
      if (*started) r.mutable_event()->set_elapsed_seconds(store::unix_now() - **started);
      if (*first) {
        *first = false;
        *answer = std::move(r);
      } else {
        on_event(r);
      }
    });
    if (sub) {
      *handle = std::move(sub);
      return;
    }
  }
  // Not running or queued here: answer from the database with one final event.
  const auto record = db_->get(id);
  if (!record) fail(v1::Error::NOT_FOUND, "no job " + id, "job_id");
  *resp.mutable_event() = event_of(*record);
  resp.mutable_event()->set_final(true);
}

void Service::cancel(const v1::Request& req, v1::Response& resp) {
  const std::string id = checked_job_id(req.cancel().job_id(), "job_id");
  const auto record = db_->get(id);
  if (!record) fail(v1::Error::NOT_FOUND, "no job " + id, "job_id");
  switch (queue_->cancel(id)) {
    case store::CancelOutcome::removed_from_queue: {
      const store::JobRecord r = db_->mark_cancelled(id);
      queue_->finish(id, store::Progress{store::JobState::cancelled, 0, {}, 0, {}, "cancelled before it ran"});
      log_line("job " + id, "cancelled while queued");
      resp.mutable_cancel()->set_state(to_proto(r.state));
      return;
    }
    case store::CancelOutcome::signalled:
      // The worker records the cancellation when the bake stops (at its next check).
      resp.mutable_cancel()->set_state(v1::JOB_STATE_CANCELLED);
      log_line("job " + id, "cancel requested while running");
      return;
    case store::CancelOutcome::unknown:
      resp.mutable_cancel()->set_state(to_proto(record->state));
      return;
  }
}

void Service::result(const v1::Request& req, v1::Response& resp) {
  const std::string id = checked_job_id(req.get_result().job_id(), "job_id");
  const auto record = db_->get(id);
  if (!record) fail(v1::Error::NOT_FOUND, "no job " + id, "job_id");
  v1::JobResult* r = resp.mutable_result();
  if (record->state == store::JobState::succeeded) {
    const std::string& stored = record->result;
    if (record->evicted) {
      fail(v1::Error::NOT_FOUND,
           "the outputs of job " + id +
               " are gone from the store (evicted by its retention limit, or found damaged); "
               "submit the job again to bake them anew",
           "job_id");
    }
    if (!r->ParseFromString(stored)) fail(v1::Error::DATA_LOSS, "the stored result of job " + id + " is unreadable");
    if (record->cache_source) r->mutable_report()->set_cache_hit(true);
    db_->touch(id);
  }
  r->set_job_id(id);
  r->set_state(to_proto(record->state));
  r->set_name(record->name);
  r->set_submitted_unix(record->submitted);
  if (record->finished) r->set_finished_unix(*record->finished);
  if (record->state == store::JobState::failed) {
    // The workers record a failure the job's input caused as "FIELD: problem" with FIELD a path under "job."
    // (translate.h's InvalidField); anything else is the server's fault.
    const std::string& text = record->error;
    const auto colon = text.find(": ");
    const bool input = text.rfind("job.", 0) == 0 && colon != std::string::npos && text.find(' ') > colon;
    r->mutable_error()->set_code(input ? v1::Error::INVALID_ARGUMENT : v1::Error::INTERNAL);
    r->mutable_error()->set_message(text);
    if (input) r->mutable_error()->set_field(text.substr(0, colon));
  }
}

void Service::fetch(const v1::Request& req, v1::Response& resp) {
  const auto& f = req.fetch();
  const store::BlobId id = checked_digest(f.digest(), "digest", config_.max_blob_bytes);
  if (f.offset() > id.size) fail(v1::Error::INVALID_ARGUMENT, "past the end of the blob", "offset");
  if (f.length() > config_.max_chunk_bytes) {
    fail(v1::Error::INVALID_ARGUMENT, "at most " + std::to_string(config_.max_chunk_bytes) + " bytes", "length");
  }
  if (!blobs_->contains(id)) fail(v1::Error::NOT_FOUND, "no blob " + id.digest + " in the store", "digest");
  const uint64_t length = f.length() == 0 ? config_.max_chunk_bytes : f.length();
  auto* reply = resp.mutable_fetch();
  reply->set_offset(f.offset());
  try {
    reply->set_data(blobs_->read_range(id, f.offset(), length));
  } catch (const store::StoreError& e) {
    // A damaged blob was moved aside: every result that refers to it leaves the cache, so that submitting the job
    // again bakes it instead of answering with outputs that cannot be fetched.
    if (e.code() == store::StoreErrc::data_loss) {
      const size_t n = db_->mark_results_evicted({id.digest});
      log_line("store " + config_.store,
               std::string(e.what()) + "; " + std::to_string(n) + " result(s) referring to it left the result cache");
    }
    throw;
  }
  reply->set_eof(f.offset() + reply->data().size() >= id.size);
}

void Service::status(v1::Response& resp) {
  const store::JobCounts c = db_->counts();
  auto* s = resp.mutable_status();
  s->set_server_version(kServerVersion);
  s->set_uptime_seconds(std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count());
  s->set_queued(static_cast<uint32_t>(queue_->size()));
  s->set_running(static_cast<uint32_t>(queue_->running()));
  s->set_workers(config_.workers);
  s->set_threads(config_.threads == 0 ? std::thread::hardware_concurrency() : config_.threads);
  s->set_store_bytes(blobs_->size_on_disk());
  s->set_store_limit_bytes(config_.store_limit_bytes);
  s->set_cache_hits(c.cache_hits);
  s->set_jobs_completed(c.succeeded);
  s->set_jobs_failed(c.failed);
  s->set_connections(static_cast<uint32_t>(std::max(0, connections_.load())));
}

void Service::list_jobs(const v1::Request& req, v1::Response& resp) {
  const auto& l = req.list_jobs();
  if (!bounds::kListJobsLimit.contains(l.limit())) {
    fail(v1::Error::INVALID_ARGUMENT,
         "must be in [" + std::to_string(bounds::kListJobsLimit.lo) + ", " + std::to_string(bounds::kListJobsLimit.hi) +
             "]",
         "limit");
  }
  std::optional<store::JobState> state;
  switch (l.state()) {
    case v1::JOB_STATE_UNSPECIFIED:
      break;
    case v1::JOB_STATE_QUEUED:
      state = store::JobState::queued;
      break;
    case v1::JOB_STATE_RUNNING:
      state = store::JobState::running;
      break;
    case v1::JOB_STATE_SUCCEEDED:
      state = store::JobState::succeeded;
      break;
    case v1::JOB_STATE_FAILED:
      state = store::JobState::failed;
      break;
    case v1::JOB_STATE_CANCELLED:
      state = store::JobState::cancelled;
      break;
    default:
      fail(v1::Error::INVALID_ARGUMENT, "unknown state", "state");
  }
  auto* list = resp.mutable_jobs();
  for (const store::JobRecord& r : db_->list(l.limit() == 0 ? 100 : l.limit(), state)) {
    auto* j = list->add_jobs();
    j->set_job_id(r.id);
    j->set_name(r.name);
    j->set_type(r.type);
    j->set_state(to_proto(r.state));
    j->set_priority(r.priority);
    j->set_submitted_unix(r.submitted);
    if (r.started) j->set_seconds((r.finished ? *r.finished : store::unix_now()) - *r.started);
    j->set_cache_hit(r.cache_source.has_value());
  }
}

}  // namespace kiln::daemon
