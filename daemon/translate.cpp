// The translation layer's entry points: which job a spec holds, and what every job type has in common (its
// blobs, the errors its baker raises, its version, its canonical text and cache key). Each job type's fields are
// translated in its own file (translate_material.cpp, translate_environment.cpp, translate_lightmap.cpp).
#include "daemon/translate.h"

#include <algorithm>
#include <array>

#include "bakers/envmap/dfg_cache.h"
#include "daemon/translate_fields.h"
#include "proto/digest.h"
#include "proto/kiln.pb.h"

namespace kiln::daemon {

const char* const kBakerVersion = material::kMaterialBakerVersion;

namespace {

constexpr std::size_t kMaxNameBytes = 256;
constexpr std::size_t kMaxForcedEffects = 64;

// In the order of BakeRequest::input's alternatives.
constexpr std::array<const char*, 3> kJobTypes = {"material", "environment", "lightmap"};
static_assert(std::variant_size_v<decltype(BakeRequest::input)> == kJobTypes.size());

// The lightmap bake names the texture ("textures[I]") or the environment ("environment_image") whose bytes do not
// decode, as the blob fields "job.lightmap.textures[I].image" and "job.lightmap.environment.image" hold them; a time
// limit that ran out during the set-up as the quality's field; and no field for a scene with nothing to bake: the
// whole job's.
InvalidField lightmap_input_error(const BakeRequest& r, const bake::InvalidInput& problem) {
  const std::string& field = problem.field();
  if (field == "time_limit_seconds") return InvalidField("job.quality.time_limit_seconds", problem.problem());
  std::string part;
  if (field.rfind("textures[", 0) == 0) part = "." + field + ".";
  if (field == "environment_image") part = ".environment.";
  for (const BlobRef& ref : r.inputs) {
    if (!part.empty() && ref.field.find(part) != std::string::npos) return InvalidField(ref.field, problem.problem());
  }
  // A probes job: its settings' fields under its volume, the rest under its scene.
  if (!r.lightmap().lightmaps) {
    if (field.rfind("probes.", 0) == 0) return InvalidField("job.probes.volume" + field.substr(6), problem.problem());
    return detail::baker_problem("job.probes.scene", problem);
  }
  return detail::baker_problem("job.lightmap", problem);
}

}  // namespace

const char* job_type(const BakeRequest& request) {
  const auto* lightmap = std::get_if<lightmap::LightmapBakeInput>(&request.input);
  if (lightmap && !lightmap->lightmaps) return "probes";
  return kJobTypes[request.input.index()];
}

BakeRequest translate(const kiln::v1::JobSpec& spec, const store::BlobStore* blobs) {
  BakeRequest r;
  if (spec.name().size() > kMaxNameBytes) {
    throw InvalidField(
        "job.name", "at most " + std::to_string(kMaxNameBytes) + " bytes, got " + std::to_string(spec.name().size()));
  }
  r.name = spec.name();
  if (spec.force_effects_size() > static_cast<int>(kMaxForcedEffects)) {
    throw InvalidField("job.force_effects", "at most " + std::to_string(kMaxForcedEffects) + " entries, got " +
                                                std::to_string(spec.force_effects_size()));
  }
  switch (spec.job_case()) {
    case kiln::v1::JobSpec::kMaterial:
      detail::translate_material(spec, r);
      break;
    case kiln::v1::JobSpec::kEnvironment:
      detail::translate_environment(spec, blobs, r);
      break;
    case kiln::v1::JobSpec::kLightmap:
      detail::translate_lightmap(spec, blobs, r);
      break;
    case kiln::v1::JobSpec::kProbes:
      detail::translate_probes(spec, blobs, r);
      break;
    default:
      throw InvalidField("job", "no job given: set material, environment, lightmap or probes");
  }
  return r;
}

void load_inputs(BakeRequest& r, store::BlobStore& blobs) {
  if (std::holds_alternative<lightmap::LightmapBakeInput>(r.input)) return detail::load_lightmap_inputs(r, blobs);
  if (std::holds_alternative<envmap::EnvironmentBakeInput>(r.input)) detail::load_environment_inputs(r, blobs);
}

InvalidField input_error(const BakeRequest& r, const std::exception& e) {
  const std::string prefix = std::string("job.") + job_type(r);
  const bool is_lightmap = std::holds_alternative<lightmap::LightmapBakeInput>(r.input);
  if (const auto* problem = dynamic_cast<const bake::InvalidInput*>(&e)) {
    return is_lightmap ? lightmap_input_error(r, *problem) : detail::baker_problem(prefix, *problem);
  }
  // Anything else the bakers raise about their input concerns the bytes they decode: an environment's image or
  // faces; for a lightmap job, which bytes is not known, so the job as a whole.
  if (is_lightmap || r.inputs.empty()) return InvalidField(prefix, e.what());
  return InvalidField(r.inputs.size() == 1 ? r.inputs[0].field : prefix + ".faces", e.what());
}

const char* baker_version(const BakeRequest& r) {
  if (std::holds_alternative<lightmap::LightmapBakeInput>(r.input)) return lightmap::kLightmapBakerVersion;
  if (std::holds_alternative<envmap::EnvironmentBakeInput>(r.input)) return envmap::kEnvironmentBakerVersion;
  return material::kMaterialBakerVersion;
}

std::string canonical_text(const BakeRequest& r) {
  if (std::holds_alternative<envmap::EnvironmentBakeInput>(r.input)) return detail::environment_canonical_text(r);
  if (std::holds_alternative<lightmap::LightmapBakeInput>(r.input)) return detail::lightmap_canonical_text(r);
  return detail::material_canonical_text(r);
}

void size_vdb_media(BakeRequest& r, store::BlobStore& blobs) {
  if (std::holds_alternative<lightmap::LightmapBakeInput>(r.input)) detail::size_lightmap_vdb_media(r, blobs);
}

void fit_memory_limit(BakeRequest& r, uint64_t server_limit) {
  if (!std::holds_alternative<lightmap::LightmapBakeInput>(r.input) || !r.lightmap_memory) return;
  const uint64_t own = r.lightmap().memory_limit_bytes;
  const uint64_t limit = own == 0 || server_limit == 0 ? std::max(own, server_limit) : std::min(own, server_limit);
  detail::plan_lightmap_memory(r, limit);
}

void keep_baker_tables_in(const std::string& folder) { envmap::keep_dfg_tables_in(folder); }

std::string cache_key(const BakeRequest& request, const std::string& baker_version) {
  return proto::sha256_hex(canonical_text(request) + "baker=" + baker_version + "\n");
}

}  // namespace kiln::daemon
