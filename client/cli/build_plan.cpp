#include "client/cli/build_plan.h"

#include <fnmatch.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <set>
#include <system_error>

#include "client/cli/bake_flags.h"
#include "client/cli/build_checks.h"
#include "client/cli/env_flags.h"
#include "client/cli/job_file.h"
#include "client/cli/lightmap_flags.h"
#include "client/cli/probes_flags.h"
#include "client/lib/client.h"

namespace kiln::cli {
namespace {

namespace fs = std::filesystem;

// Flags of `kiln bake` that do not describe the job, and what gives them in a build.
struct RefusedFlag {
  const char* flag;
  const char* instead;
};
constexpr RefusedFlag kRefusedFlags[] = {
    {"--out", "the bake's `output` folder"},
    {"--wait", "`kiln build`, which always waits"},
    {"--priority", "the bake's `priority`"},
    {"--idempotency-key", "nothing: a build resubmits identical jobs, which the result cache answers"},
    {"--server", "`kiln build --server`"},
    {"--token-file", "`kiln build --token-file`"},
    {"--tls-ca", "`kiln build --tls-ca`"},
    {"--tls-cert", "`kiln build --tls-cert`"},
    {"--tls-key", "`kiln build --tls-key`"},
    {"--help", "nothing"},
};

std::string read_bytes(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (!in && !in.eof()) throw UsageError("cannot read " + file.string() + ": " + std::strerror(errno));
  return bytes;
}

// The digest of `file`, whose bytes join the plan's blobs.
v1::Digest add_file_blob(BuildPlan& plan, const fs::path& file) {
  std::string bytes = read_bytes(file);
  v1::Digest digest = client::digest_of(bytes);
  plan.blobs.emplace(digest.sha256(), std::move(bytes));
  return digest;
}

std::string job_type_of(const v1::JobSpec& spec) {
  switch (spec.job_case()) {
    case v1::JobSpec::kMaterial:
      return "material";
    case v1::JobSpec::kEnvironment:
      return "environment";
    case v1::JobSpec::kLightmap:
      return "lightmap";
    case v1::JobSpec::kProbes:
      return "probes";
    default:
      return "job";
  }
}

// The files a glob matches: wildcards in the last part of the path only, hidden files only when the pattern starts
// with '.'; in name order.
std::vector<fs::path> glob_files(const fs::path& pattern) {
  const fs::path dir = pattern.parent_path();
  const std::string name = pattern.filename().string();
  if (dir.string().find_first_of("*?[") != std::string::npos) {
    throw UsageError("inputs " + pattern.string() + ": wildcards go in the file name only, not in its folders");
  }
  std::vector<fs::path> files;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const std::string file = entry.path().filename().string();
    if (entry.is_regular_file(ec) && fnmatch(name.c_str(), file.c_str(), FNM_PERIOD) == 0) {
      files.push_back(entry.path());
    }
  }
  if (ec) throw UsageError("inputs " + pattern.string() + ": cannot list " + dir.string() + ": " + ec.message());
  if (files.empty()) throw UsageError("inputs " + pattern.string() + " matches no file");
  std::sort(files.begin(), files.end());
  return files;
}

// The words of a command as `kiln bake` flags, with the paths in them resolved against the manifest's folder.
Flags command_flags(const std::vector<std::string>& words, const fs::path& dir) {
  const std::string& type = words[0];
  std::vector<FlagSpec> specs;
  if (type == "material") {
    specs = bake_material_flag_specs();
  } else if (type == "env" || type == "environment") {
    specs = bake_env_flag_specs();
  } else if (type == "lightmap") {
    specs = bake_lightmap_flag_specs();
  } else if (type == "probes") {
    specs = bake_probes_flag_specs();
  } else {
    throw UsageError("command: unknown bake type '" + type + "': expected material, env, lightmap or probes");
  }
  Flags f = parse_flags(words, specs, "kiln bake " + type);
  for (const RefusedFlag& r : kRefusedFlags) {
    if (f.has(r.flag))
      throw UsageError(std::string("command: ") + r.flag + " has no place in a manifest; use " + r.instead);
  }
  for (std::size_t i = 1; i < f.positional.size(); ++i) f.positional[i] = resolve_path(dir, f.positional[i]).string();
  for (const char* path_flag : {"--env", "--job", "--vdb"}) {
    if (auto it = f.values.find(path_flag); it != f.values.end()) {
      for (auto& v : it->second) v = resolve_path(dir, v).string();
    }
  }
  return f;
}

void plan_material(PlannedBake& bake, const Flags& f) {
  if (f.positional.size() > 1) {
    throw UsageError("command: unexpected argument '" + f.positional[1] + "': a material bake reads no file");
  }
  bake.spec = material_spec_from_flags(f);
  bake.where = [](const std::string& field) { return flag_for_field(field); };
}

void plan_environment(PlannedBake& bake, const Flags& f, BuildPlan& plan) {
  auto env = std::make_shared<EnvironmentBake>(environment_bake_from_flags(f));
  require_environment_files(*env);
  std::vector<v1::Digest> digests;
  for (const std::string& file : env->files) digests.push_back(add_file_blob(plan, file));
  if (!env->files.empty()) set_input_digests(*env, digests);
  bake.spec = env->spec;
  bake.where = [env](const std::string& field) { return environment_field_origin(*env, field); };
}

void plan_lightmap(PlannedBake& bake, const Flags& f, BuildPlan& plan, std::ostream& err) {
  auto lightmap = std::make_shared<LightmapBake>(lightmap_bake_from_flags(f));
  require_lightmap_files(*lightmap);
  client::ImportedScene scene = import_lightmap_scene(err, *lightmap);
  merge_scene(*lightmap, scene.job);
  for (auto& [sha, bytes] : scene.blobs) plan.blobs.emplace(sha, std::move(bytes));
  if (!lightmap->env_file.empty()) {
    *lightmap->spec.mutable_lightmap()->mutable_environment()->mutable_image() =
        add_file_blob(plan, lightmap->env_file);
  }
  if (!lightmap->vdb_file.empty()) set_vdb_digest(*lightmap, add_file_blob(plan, lightmap->vdb_file));
  // `probes SCENE ...`: the same scene, made a probes job.
  const bool probes = f.positional[0] == "probes";
  if (probes) make_probes_job(lightmap->spec);
  bake.spec = lightmap->spec;
  bake.where = [lightmap, probes](const std::string& field) {
    return probes ? probes_field_origin(*lightmap, field) : lightmap_field_origin(*lightmap, field);
  };
}

void plan_job_file(PlannedBake& bake, const fs::path& file) {
  auto text = std::make_shared<std::string>();
  read_job_file(file.string(), bake.spec, *text);
  bake.where = [text, file](const std::string& field) -> std::string {
    const auto at = locate_field(*text, field);
    return file.string() + (at ? ":" + *at : "");
  };
}

PlannedBake plan_one(const ManifestBake& m, const std::string& name, const std::vector<std::string>& words,
                     const Manifest& manifest, BuildPlan& plan, std::ostream& err) {
  PlannedBake bake;
  bake.name = name;
  bake.origin = m.origin;
  bake.priority = m.priority;
  bake.checks = m.checks;
  bake.output = m.output;
  if (!m.job_file.empty()) {
    plan_job_file(bake, m.job_file);
  } else {
    const Flags f = command_flags(words, manifest.dir);
    if (words[0] == "material") {
      plan_material(bake, f);
    } else if (words[0] == "lightmap" || words[0] == "probes") {
      plan_lightmap(bake, f, plan, err);
    } else {
      plan_environment(bake, f, plan);
    }
  }
  if (bake.spec.name().empty()) bake.spec.set_name(name);
  bake.type = job_type_of(bake.spec);
  require_applicable(bake.checks, bake.type);
  return bake;
}

bool wanted(const std::vector<std::string>& only, const std::string& manifest_name, const std::string& name) {
  if (only.empty()) return true;
  return std::find(only.begin(), only.end(), manifest_name) != only.end() ||
         std::find(only.begin(), only.end(), name) != only.end();
}

}  // namespace

BuildPlan plan_build(const Manifest& manifest, const std::vector<std::string>& only, std::ostream& err) {
  BuildPlan plan;
  std::set<std::string> named;
  for (const ManifestBake& m : manifest.bakes) {
    try {
      if (m.inputs.empty()) {
        if (wanted(only, m.name, m.name)) {
          plan.bakes.push_back(plan_one(m, m.name, m.command, manifest, plan, err));
          named.insert(m.name);
        }
        continue;
      }
      if (m.command[0] == "material") throw UsageError("inputs: a material bake reads no file");
      for (const fs::path& file : glob_files(m.inputs)) {
        const std::string stem = file.stem().string();
        const std::string name = m.name + "/" + stem;
        if (!wanted(only, m.name, name)) continue;
        // The file is the command's input: the first word after the bake type.
        std::vector<std::string> words = m.command;
        words.insert(words.begin() + 1, file.string());
        PlannedBake bake = plan_one(m, name, words, manifest, plan, err);
        bake.output = m.output / stem;
        plan.bakes.push_back(std::move(bake));
        named.insert(m.name);
        named.insert(name);
      }
    } catch (const UsageError& e) {
      throw UsageError(m.origin + ": bake \"" + m.name + "\": " + e.what());
    } catch (const Failure& e) {
      throw UsageError(m.origin + ": bake \"" + m.name + "\": " + e.what());
    }
  }
  for (const std::string& name : only) {
    if (!named.count(name)) {
      throw UsageError("--only " + name + ": no bake of that name in " + manifest.file.string() +
                       " (a glob's bakes are NAME or NAME/STEM)");
    }
  }
  return plan;
}

}  // namespace kiln::cli
