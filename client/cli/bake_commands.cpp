// `kiln bake material|env|lightmap`: the flags become a job, local files are uploaded, and the job is submitted and
// followed, Ctrl-C cancelling it on the server.
#include <filesystem>
#include <functional>
#include <ostream>

#include "client/cli/bake_flags.h"
#include "client/cli/env_flags.h"
#include "client/cli/follow.h"
#include "client/cli/interrupt.h"
#include "client/cli/lightmap_flags.h"
#include "client/cli/probes_flags.h"
#include "client/cli/outputs.h"
#include "client/cli/progress.h"
#include "client/cli/subcommands.h"
#include "client/cli/submission.h"
#include "client/import/scene_import.h"
#include "proto/text.h"

namespace kiln::cli {
namespace {

namespace fs = std::filesystem;
using client::ConnectionError;
using client::ServerError;

// Submits `spec`, follows it with Ctrl-C cancelling it on the server, and saves and summarizes the result (writing
// into `dir` if given).
int submit_and_follow(Context& ctx, const v1::JobSpec& spec, const Flags& f, const std::optional<fs::path>& dir,
                      const FieldOrigin& where) {
  const v1::SubmitReply reply = submit_job(ctx, spec, priority_of(f), idempotency_key_of(f), where);
  const std::string& id = reply.job_id();
  ctx.err << "kiln: submitted job " << id << (reply.cache_hit() ? " (a cache hit: already done)" : "") << "\n";
  cancel_job_on_ctrl_c();
  v1::JobEvent final;
  try {
    final = follow_job(ctx, id, true);
  } catch (const Interrupted&) {
    quit_on_ctrl_c();
    const v1::JobState state = request_cancel(ctx, id);
    if (state != v1::JOB_STATE_CANCELLED) {
      ctx.err << "kiln: job " << id << " had already " << state_name(state) << "\n";
      final.set_state(state);
      return save_and_summarize(ctx, final, id, dir, reply.cache_hit());
    }
    throw Failure(kExitJobFailed, "job " + id + " cancelled (Ctrl-C)" +
                                      (dir ? "; nothing was written to " + dir->string() : std::string()));
  }
  quit_on_ctrl_c();
  return save_and_summarize(ctx, final, id, dir, reply.cache_hit());
}

// `kiln bake env|lightmap`: with --out or --wait, submit and follow; without, submit, print the job id and return.
int submit_and_follow_if_waiting(Context& ctx, const v1::JobSpec& spec, const Flags& f,
                                 const std::optional<fs::path>& dir, const FieldOrigin& where) {
  if (!dir && !f.has("--wait")) {
    const v1::SubmitReply reply = submit_job(ctx, spec, priority_of(f), idempotency_key_of(f), where);
    ctx.out << reply.job_id() << "\n" << std::flush;
    ctx.err << "kiln: submitted job " << reply.job_id() << " (" << state_name(reply.state())
            << (reply.cache_hit() ? ", a cache hit: already done" : "") << "); follow it with `kiln watch "
            << reply.job_id() << "`, write its outputs with `kiln fetch " << reply.job_id() << " --out DIR`\n";
    return kExitOk;
  }
  return submit_and_follow(ctx, spec, f, dir, where);
}

// Runs `upload`, turning its errors into messages that name `what` was being uploaded.
void upload_naming_errors(Context& ctx, ProgressPrinter& printer, const std::string& what,
                          const std::function<void()>& upload) {
  try {
    upload();
  } catch (const ServerError& e) {
    printer.finish();
    throw Failure(kExitServer,
                  "kilnd at " + ctx.server + " refused the upload of " + what + ": " + describe_server_error(e));
  } catch (const ConnectionError& e) {
    printer.finish();
    throw_connection_lost(ctx, e, "uploading " + what);
  } catch (const std::runtime_error& e) {
    printer.finish();
    throw Failure(kExitUsage, e.what());
  }
}

std::vector<v1::Digest> upload_environment_files(Context& ctx, const std::vector<std::string>& files) {
  std::vector<v1::Digest> digests;
  ProgressPrinter printer(ctx.err, ctx.terminal.progress_in_place, ctx.terminal.columns);
  for (const std::string& file : files) {
    const std::string label = "upload " + fs::path(file).filename().string();
    upload_naming_errors(ctx, printer, file, [&] {
      digests.push_back(connected_client(ctx).upload_file(file, [&](std::uint64_t done, std::uint64_t total) {
        printer.transfer(label, done, total, steady_seconds());
      }));
    });
  }
  printer.finish();
  return digests;
}

int cmd_bake_env(Context& ctx, const Flags& f) {
  EnvironmentBake bake = environment_bake_from_flags(f);
  priority_of(f);
  idempotency_key_of(f);  // usage errors before any upload
  const std::optional<fs::path> dir = out_dir_of(f);
  require_environment_files(bake);
  const std::vector<v1::Digest> digests = upload_environment_files(ctx, bake.files);
  if (!bake.files.empty()) set_input_digests(bake, digests);

  auto where = [&](const std::string& field) { return environment_field_origin(bake, field); };
  return submit_and_follow_if_waiting(ctx, bake.spec, f, dir, where);
}

// Every blob once (the importer keys them by digest), then the environment image; the client asks the server first
// and sends only what it lacks.
void upload_lightmap_inputs(Context& ctx, LightmapBake& bake, const client::ImportedScene& scene) {
  ProgressPrinter printer(ctx.err, ctx.terminal.progress_in_place, ctx.terminal.columns);
  std::uint64_t total = 0, sent = 0;
  for (const auto& [sha, bytes] : scene.blobs) total += bytes.size();
  const std::string label = "upload " + fs::path(bake.scene_file).filename().string();
  upload_naming_errors(ctx, printer, bake.scene_file, [&] {
    for (const auto& [sha, bytes] : scene.blobs) {
      connected_client(ctx).upload_blob(bytes, [&](std::uint64_t done, std::uint64_t) {
        printer.transfer(label, sent + done, total, steady_seconds());
      });
      sent += bytes.size();
    }
    if (!bake.env_file.empty()) {
      const std::string env_label = "upload " + fs::path(bake.env_file).filename().string();
      *bake.spec.mutable_lightmap()->mutable_environment()->mutable_image() = connected_client(ctx).upload_file(
          bake.env_file,
          [&](std::uint64_t done, std::uint64_t all) { printer.transfer(env_label, done, all, steady_seconds()); });
    }
    if (!bake.vdb_file.empty()) {
      const std::string vdb_label = "upload " + fs::path(bake.vdb_file).filename().string();
      set_vdb_digest(bake, connected_client(ctx).upload_file(bake.vdb_file, [&](std::uint64_t done, std::uint64_t all) {
        printer.transfer(vdb_label, done, all, steady_seconds());
      }));
    }
  });
  printer.finish();
}

int cmd_bake_lightmap(Context& ctx, const Flags& f) {
  LightmapBake bake = lightmap_bake_from_flags(f);
  priority_of(f);
  idempotency_key_of(f);  // usage errors before any import or upload
  const std::optional<fs::path> dir = out_dir_of(f);
  require_lightmap_files(bake);
  const client::ImportedScene scene = import_lightmap_scene(ctx.err, bake);
  merge_scene(bake, scene.job);
  upload_lightmap_inputs(ctx, bake, scene);
  // The server names a field; the user wrote a flag, a scene file, an image or a job file.
  auto where = [&](const std::string& field) { return lightmap_field_origin(bake, field); };
  return submit_and_follow_if_waiting(ctx, bake.spec, f, dir, where);
}

// `kiln bake probes`: the lightmap bake's scene, made a probes job once merged.
int cmd_bake_probes(Context& ctx, const Flags& f) {
  LightmapBake bake = lightmap_bake_from_flags(f);
  priority_of(f);
  idempotency_key_of(f);
  const std::optional<fs::path> dir = out_dir_of(f);
  require_lightmap_files(bake);
  const client::ImportedScene scene = import_lightmap_scene(ctx.err, bake);
  merge_scene(bake, scene.job);
  upload_lightmap_inputs(ctx, bake, scene);
  make_probes_job(bake.spec);
  auto where = [&](const std::string& field) { return probes_field_origin(bake, field); };
  return submit_and_follow_if_waiting(ctx, bake.spec, f, dir, where);
}

int cmd_bake_material(Context& ctx, const Flags& f) {
  if (f.positional.size() > 1) {
    throw UsageError("unexpected argument '" + f.positional[1] + "' (see `kiln bake material --help`)");
  }
  const v1::JobSpec spec = material_spec_from_flags(f);
  priority_of(f);
  idempotency_key_of(f);
  const auto out = f.get("--out");
  if (!out) throw UsageError("--out: missing; bake writes its outputs into a folder: add --out DIR");
  const fs::path dir = create_out_dir(*out);
  return submit_and_follow(ctx, spec, f, dir, [](const std::string& field) { return flag_for_field(field); });
}

}  // namespace

int cmd_bake(Context& ctx, const Flags& f) {
  if (f.positional.empty()) {
    throw UsageError(
        "missing job type: `kiln bake material ...` or `kiln bake env ...` (see `kiln bake material "
        "--help`, `kiln bake env --help`)");
  }
  if (f.positional[0] == "env" || f.positional[0] == "environment") return cmd_bake_env(ctx, f);
  if (f.positional[0] == "lightmap") return cmd_bake_lightmap(ctx, f);
  if (f.positional[0] == "probes") return cmd_bake_probes(ctx, f);
  if (f.positional[0] != "material") {
    throw UsageError("unknown job type '" + f.positional[0] +
                     "': `kiln bake` bakes material, env, lightmap or probes (see `kiln bake material --help`, `kiln "
                     "bake env --help`, `kiln bake lightmap --help`, `kiln bake probes --help`)");
  }
  return cmd_bake_material(ctx, f);
}

}  // namespace kiln::cli
