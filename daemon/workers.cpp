#include "daemon/workers.h"

#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <iostream>

#include "bakers/lightmap/memory_estimate.h"
#include "daemon/log.h"
#include "daemon/memory_budget.h"
#include "daemon/store/blob_store.h"
#include "daemon/store/job_db.h"
#include "daemon/store/job_queue.h"
#include "daemon/translate.h"
#include "proto/kiln.pb.h"

namespace kiln::daemon {

// An output as the worker keeps it once its bytes are in the blob store.
struct StoredOutput {
  std::string name, media_type, color_space;
  store::BlobId blob;
  std::string report_json;  // the bytes of report.json, which the JobResult carries too; empty for the others
};

// What any bake hands back to the worker.
struct Baked {
  std::vector<StoredOutput> outputs;
  uint64_t samples = 0;
  uint64_t rays = 0;
  double seconds = 0;
  double error_estimate = 0;
  std::vector<v1::PlanDecision> plan;
};

Workers::Workers(const Config& config, store::JobRecords& db, store::BlobStore& blobs, store::WorkQueue& queue,
                 MemoryBudget& memory)
    : config_(config), db_(db), blobs_(blobs), queue_(queue), memory_(memory) {
  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const int total = config.threads == 0 ? cores : static_cast<int>(config.threads);
  // The baking threads are shared out among the jobs that run at once.
  threads_per_job_ = std::max(1, total / static_cast<int>(std::max(1u, config.workers)));
}

Workers::~Workers() { join(); }

void Workers::start() {
  for (uint32_t i = 0; i < config_.workers; ++i) {
    threads_.emplace_back([this](std::stop_token stop) { run(stop); });
  }
}

void Workers::join() {
  for (auto& t : threads_) t.request_stop();
  for (auto& t : threads_) {
    if (t.joinable()) t.join();
  }
  threads_.clear();
}

void Workers::run(std::stop_token stop) {
  while (!stop.stop_requested()) {
    std::unique_lock admission(admission_);
    std::optional<store::QueuedJob> job = queue_.pop(stop);
    if (!job) return;
    run_one(job->id, job->cancel, stop, admission);
  }
}

namespace {

std::string describe_output(const std::string& n) {
  if (n == "albedo.exr") return "directional albedo E(mu) with standard errors, and the white-furnace E";
  if (n == "split_sum.exr") return "split-sum scale and bias on f0 over (mu, roughness), with standard errors";
  if (n == "brdf.merl") return "the BRDF tabulated in the MERL binary layout (90 x 90 x 180 x RGB doubles)";
  if (n == "report.json") return "the bake report: samples, time, errors, validation, plan";
  if (n == "lightmaps.json") return "the atlas manifest: each instance's page, scale and offset, each page's files";
  if (n == "specular.ktx2") return "the prefiltered specular cube, every level and face, RGBA16F";
  if (n.rfind("specular_L", 0) == 0) return "one face of one level of the prefiltered specular cube, RGB float";
  if (n.rfind("irradiance_", 0) == 0) return "one face of the irradiance cube E(n), RGB float";
  if (n == "sh.txt") return "nine RGB irradiance coefficients (order-2 spherical harmonics)";
  if (n == "dfg.exr") return "the DFG table: split-sum scale, bias and energy over (mu, roughness)";
  if (n == "preview.png") return "a preview: spheres of several roughnesses lit by the environment";
  if (n == "probes.vdb") return "light probes: order-2 SH of radiance per probe, validity and error (OpenVDB grids)";
  if (n == "probes_preview.png") return "a layer of light probes as white spheres lit by them, for people";
  // Lightmap outputs, NAME_<kind>.<ext> for each lightmap NAME (lightmap_bake.h).
  auto ends = [&](const char* tail) {
    const std::string t = tail;
    return n.size() > t.size() && n.compare(n.size() - t.size(), t.size(), t) == 0;
  };
  if (ends("_irradiance_denoised.exr")) return "the irradiance through the denoiser (report.json says which), dilated";
  if (ends("_irradiance.exr")) return "irradiance E (W/m^2) per lightmap texel, RGB float, dilated by the padding";
  if (ends("_validity.exr")) return "texel validity: 1 valid, 0 invalid (before dilation)";
  if (ends("_error.exr")) return "the estimated relative standard error of each texel's irradiance";
  if (ends("_radiance.exr")) return "baked diffuse radiance rho E / pi per texel, RGB float";
  if (ends("_ao.exr")) return "ambient occlusion per texel";
  if (ends("_sh.exr")) return "order-1 spherical harmonics of incoming radiance: 4 RGB coefficients (12 channels)";
  if (ends("_preview.png")) return "the irradiance lightmap through the display transform, for people";
  if (ends("_uv.bin")) return "the mesh with its generated lightmap UVs, in the kiln mesh layout (kiln.proto)";
  return {};
}

void add_decision(Baked& b, const std::string& effect, bool enabled, bool forced, const std::string& reason) {
  v1::PlanDecision& d = b.plan.emplace_back();
  d.set_effect(effect);
  d.set_enabled(enabled);
  d.set_forced(forced);
  d.set_reason(reason);
}

// The bakers that return their outputs: each goes to the control's sink after the bake, as a streaming bake's would
// during it.
void stream_returned(std::vector<bake::BakeOutput>& outputs, const bake::BakeControl& control) {
  for (bake::BakeOutput& o : outputs) control.output_sink(std::move(o));
  outputs.clear();
}

Baked run_baker(const BakeRequest&, const material::MaterialBakeInput& in, const bake::BakeControl& control) {
  material::MaterialBakeResult r = material::bake_material(in, control);
  Baked b;
  stream_returned(r.outputs, control);
  b.samples = r.samples + r.validation_samples;
  b.seconds = r.seconds;
  b.error_estimate = r.max_error_estimate;
  for (const std::string& line : r.plan) add_decision(b, "material", true, false, line);
  return b;
}

// Runs a baker whose bad input is the job's fault: an input it refuses (bake::InvalidInput) or bytes that do not
// decode (std::runtime_error, the bakers' contract) become InvalidField naming the job's field. Anything else
// (bad_alloc, a logic error) is the server's and stays so.
template <class Bake>
auto blaming_input(const BakeRequest& request, Bake&& bake) {
  try {
    return bake();
  } catch (const bake::BakeCancelled&) {
    throw;
  } catch (const bake::InvalidInput& e) {
    throw input_error(request, e);
  } catch (const std::runtime_error& e) {
    throw input_error(request, e);
  }
}

Baked run_baker(const BakeRequest& request, const envmap::EnvironmentBakeInput& in, const bake::BakeControl& control) {
  envmap::EnvironmentBakeResult r = blaming_input(request, [&] { return envmap::bake_environment(in, control); });
  Baked b;
  stream_returned(r.outputs, control);
  b.samples = r.samples;
  b.seconds = r.seconds;
  for (double e : r.level_error) b.error_estimate = std::max(b.error_estimate, e);
  for (const envmap::EnvironmentPlanEntry& e : r.plan_entries) add_decision(b, e.effect, e.enabled, e.forced, e.reason);
  if (r.sanitized.total() > 0) {
    add_decision(b, "sanitize", true, false,
                 "texels that are not usable radiance were replaced: " + std::to_string(r.sanitized.nan) +
                     " NaN (by 0), " + std::to_string(r.sanitized.inf) +
                     " infinite (+Inf by the largest finite value, -Inf by 0), " +
                     std::to_string(r.sanitized.negative) + " negative (by 0)");
  }
  return b;
}

Baked run_baker(const BakeRequest& request, const lightmap::LightmapBakeInput& in, const bake::BakeControl& control) {
  // The baker's contract (lightmap_bake.h): undecodable textures or environment, a scene with nothing to bake.
  // It streams: each page's images reach the store as soon as they are encoded (control.output_sink).
  lightmap::LightmapBakeResult r = blaming_input(request, [&] { return lightmap::bake_lightmaps(in, control); });
  Baked b;
  stream_returned(r.outputs, control);
  b.samples = r.samples;
  b.rays = r.rays;
  b.seconds = r.seconds;
  b.error_estimate = r.error_estimate;
  for (const plan::Decision& e : r.plan) add_decision(b, e.effect, e.enabled, e.forced, e.reason);
  return b;
}

// The job's outputs and figures as the protocol reports them.
v1::JobResult job_result(const std::string& id, const store::JobRecord& record, const BakeRequest& request,
                         const Baked& baked) {
  v1::JobResult result;
  result.set_job_id(id);
  result.set_state(v1::JOB_STATE_SUCCEEDED);
  result.set_name(record.name);
  result.set_submitted_unix(record.submitted);
  result.set_finished_unix(store::unix_now());
  for (const StoredOutput& o : baked.outputs) {
    v1::Output* out = result.add_outputs();
    out->set_name(o.name);
    out->set_media_type(o.media_type);
    out->set_color_space(o.color_space);
    out->set_description(describe_output(o.name));
    out->mutable_digest()->set_sha256(o.blob.digest);
    out->mutable_digest()->set_size(o.blob.size);
    if (o.name == "report.json") result.mutable_report()->set_json(o.report_json);
  }
  v1::BakeReport* report = result.mutable_report();
  report->set_samples(baked.samples);
  report->set_rays(baked.rays);
  report->set_seconds(baked.seconds);
  report->set_error_estimate(baked.error_estimate);
  report->set_baker_version(baker_version(request));
  for (const v1::PlanDecision& d : baked.plan) *report->add_plan() = d;
  return result;
}

}  // namespace

void Workers::run_one(const std::string& id, const std::shared_ptr<std::atomic<bool>>& cancel, std::stop_token stop,
                      std::unique_lock<std::mutex>& admission) {
  const auto t0 = std::chrono::steady_clock::now();
  // The request first: its memory estimate decides when the job may run.
  BakeRequest request;
  try {
    const std::optional<store::JobRecord> queued = db_.get(id);
    if (!queued) throw std::runtime_error("the job's record is gone from the database");
    request = request_of(*queued);
  } catch (const store::StoreError& e) {
    admission.unlock();
    if (e.code() == store::StoreErrc::unavailable) return hand_back(id, e.what());
    record_failure(id, e.what());
    return;
  } catch (const std::exception& e) {
    admission.unlock();
    record_failure(id, e.what());
    return;
  }
  const bool reserved = wait_for_memory(id, request, *cancel, stop);
  admission.unlock();
  if (!reserved) return;
  const MemoryReservation reservation(memory_, request.memory_bytes);
  std::optional<store::JobRecord> record = start_running(id);
  if (!record) return;
  try {
    // Its blobs were checked at submit; load_inputs reads them now and says which is gone.
    load_inputs(request, blobs_);
    const Baked baked = bake(id, request, cancel.get());
    record_success(id, *record, request, baked, t0);
  } catch (const bake::BakeCancelled&) {
    record_cancelled(id);
  } catch (const std::exception& e) {
    record_failure(id, e.what());
  }
}

bool Workers::wait_for_memory(const std::string& id, const BakeRequest& request, const std::atomic<bool>& cancel,
                              std::stop_token stop) {
  const auto give_up = [&] { return cancel.load() || stop.stop_requested() || queue_.is_shut_down(); };
  if (memory_.reserve(request.memory_bytes, [&] { return true; })) return true;
  const std::string why = "waiting for memory: it needs about " + lightmap::format_bytes(request.memory_bytes) +
                          " and the running jobs hold " + lightmap::format_bytes(memory_.in_use()) + " of the " +
                          lightmap::format_bytes(memory_.limit()) + " memory limit";
  log_line("job " + id, why);
  queue_.publish(id, store::Progress{store::JobState::queued, 0, {}, 0, {}, why});
  if (memory_.reserve(request.memory_bytes, give_up)) return true;
  if (cancel.load() && !stop.stop_requested() && !queue_.is_shut_down()) {
    db_.mark_cancelled(id);
    log_line("job " + id, "cancelled while waiting for memory");
    queue_.finish(id, store::Progress{store::JobState::cancelled, 0, {}, 0, {}, "cancelled before it ran"});
  } else {
    log_line("job " + id, "still queued at the shutdown; it runs after the next start");
    queue_.finish(id, store::Progress{store::JobState::queued, 0, {}, 0, {}, "queued until kilnd starts again"});
  }
  return false;
}

std::optional<store::JobRecord> Workers::start_running(const std::string& id) {
  store::JobRecord record;
  try {
    record = db_.mark_running(id);
  } catch (const std::exception& e) {
    // Cancelled or removed between the queue and here: nothing to run.
    log_line("job " + id, std::string("not run: ") + e.what());
    queue_.finish(id, store::Progress{store::JobState::cancelled, 0, {}, 0, {}, e.what()});
    return std::nullopt;
  }
  log_line("job " + id, "running (" + record.type + (record.name.empty() ? "" : ", " + record.name) + ", attempt " +
                            std::to_string(record.attempts) + ")");
  queue_.publish(id, store::Progress{store::JobState::running, 0, {}, 0, {}, "started"});
  return record;
}

BakeRequest Workers::request_of(const store::JobRecord& record) {
  v1::JobSpec spec;
  if (!spec.ParseFromString(record.spec)) throw std::runtime_error("the stored job spec is unreadable");
  // The database keeps the spec as the client sent it, not the translated request (a plain struct, which may hold
  // the bytes of the job's blobs): so the worker translates it again, the same text giving the same request.
  BakeRequest request = translate(spec);
  // The estimate's VDB media part as at submit, from their files (still pinned in the store).
  size_vdb_media(request, blobs_);
  // The same tiles as at submit: the limit is kilnd's, which a restart may have changed (the job then bakes under
  // the new one).
  fit_memory_limit(request, memory_.limit());
  return request;
}

Baked Workers::bake(const std::string& id, const BakeRequest& request, std::atomic<bool>* cancel) {
  bake::BakeControl control;
  control.cancel = cancel;
  // Watchers need a few updates a second, not one per table entry.
  auto last_publish = std::chrono::steady_clock::time_point{};
  control.progress = [&](const bake::BakeProgress& p) {
    const auto now = std::chrono::steady_clock::now();
    if (now - last_publish < std::chrono::milliseconds(100) && p.fraction < 1.0) return;
    last_publish = now;
    store::Progress progress{store::JobState::running, p.fraction, {}, p.samples, {}, p.stage};
    if (p.eta_seconds >= 0) progress.eta_seconds = p.eta_seconds;
    if (p.error_estimate > 0) progress.error_estimate = p.error_estimate;
    queue_.publish(id, progress);
  };
  // Every output goes into the blob store as soon as the bake hands it over, and only its digest stays: a bake of
  // many lightmap pages never holds all their images. A bake that then fails or is cancelled leaves its stored
  // outputs unreferenced, for retention to evict.
  std::vector<StoredOutput> stored;
  control.output_sink = [&](bake::BakeOutput&& o) {
    StoredOutput s{o.name, o.media_type, o.color_space, blobs_.put(o.bytes), {}};
    if (o.name == "report.json") s.report_json = std::move(o.bytes);
    stored.push_back(std::move(s));
  };
  Baked baked;
  tbb::task_arena arena(threads_per_job_);
  arena.execute(
      [&] { baked = std::visit([&](const auto& in) { return run_baker(request, in, control); }, request.input); });
  baked.outputs = std::move(stored);
  return baked;
}

void Workers::record_success(const std::string& id, const store::JobRecord& record, const BakeRequest& request,
                             const Baked& baked, std::chrono::steady_clock::time_point t0) {
  v1::JobResult result = job_result(id, record, request, baked);
  std::vector<std::string> digests;
  for (const StoredOutput& o : baked.outputs) digests.push_back(o.blob.digest);
  std::string bytes;
  result.SerializeToString(&bytes);
  db_.mark_succeeded(id, bytes, digests);
  const v1::BakeReport& report = result.report();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  log_line("job " + id, "succeeded in " + std::to_string(seconds) + " s, " + std::to_string(report.samples()) +
                            " samples, error estimate " + std::to_string(report.error_estimate()));
  queue_.finish(
      id, store::Progress{store::JobState::succeeded, 1.0, 0.0, report.samples(), report.error_estimate(), "done"});
}

void Workers::record_cancelled(const std::string& id) {
  if (requeue_) {
    db_.mark_queued(id);
    log_line("job " + id, "interrupted by the shutdown; it runs again at the next start");
    queue_.finish(id, store::Progress{store::JobState::queued, 0, {}, 0, {}, "re-queued by a daemon shutdown"});
  } else {
    db_.mark_cancelled(id);
    log_line("job " + id, "cancelled");
    queue_.finish(id, store::Progress{store::JobState::cancelled, 0, {}, 0, {}, "cancelled"});
  }
}

void Workers::hand_back(const std::string& id, const std::string& why) {
  log_line("job " + id, "not started, back to the queue: " + why);
  queue_.finish(id, store::Progress{store::JobState::queued, 0, {}, 0, {}, "handed back: " + why});
}

void Workers::record_failure(const std::string& id, const std::string& what) {
  try {
    db_.mark_failed(id, what);
  } catch (const std::exception& e2) {
    log_line("job " + id, std::string("could not record the failure: ") + e2.what());
  }
  log_line("job " + id, std::string("failed: ") + what);
  queue_.finish(id, store::Progress{store::JobState::failed, 0, {}, 0, {}, what});
}

}  // namespace kiln::daemon
