// The translation layer's entry points: which job a spec holds, and what every job type has in common (its
// blobs, the errors its baker raises, its version, its canonical text and cache key). Each job type's fields are
// translated in its own file (translate_material.cpp, translate_environment.cpp, translate_lightmap.cpp).
#include "daemon/translate.h"

#include <array>

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

}  // namespace

const char* job_type(const BakeRequest& request) { return kJobTypes[request.input.index()]; }

BakeRequest translate(const kiln::v1::JobSpec& spec, const store::BlobStore* blobs) {
  BakeRequest r;
  if (spec.name().size() > kMaxNameBytes) {
    throw InvalidField("job.name", "at most " + std::to_string(kMaxNameBytes) + " bytes, got " +
                                       std::to_string(spec.name().size()));
  }
  r.name = spec.name();
  if (spec.force_effects_size() > static_cast<int>(kMaxForcedEffects)) {
    throw InvalidField("job.force_effects", "at most " + std::to_string(kMaxForcedEffects) + " entries, got " +
                                                std::to_string(spec.force_effects_size()));
  }
  switch (spec.job_case()) {
    case kiln::v1::JobSpec::kMaterial: detail::translate_material(spec, r); break;
    case kiln::v1::JobSpec::kEnvironment: detail::translate_environment(spec, blobs, r); break;
    case kiln::v1::JobSpec::kLightmap: detail::translate_lightmap(spec, blobs, r); break;
    default: throw InvalidField("job", "no job given: set material, environment or lightmap");
  }
  return r;
}

void load_inputs(BakeRequest& r, store::BlobStore& blobs) {
  if (std::holds_alternative<lightmap::LightmapBakeInput>(r.input)) return detail::load_lightmap_inputs(r, blobs);
  if (std::holds_alternative<envmap::EnvironmentBakeInput>(r.input)) detail::load_environment_inputs(r, blobs);
}

InvalidField input_error(const BakeRequest& r, const std::exception& e) {
  const std::string prefix = std::string("job.") + job_type(r);
  if (const auto* problem = dynamic_cast<const bake::InvalidInput*>(&e)) return detail::baker_problem(prefix, *problem);
  // Anything else the bakers raise about their input concerns the bytes they decode.
  std::string field = prefix;
  if (std::holds_alternative<lightmap::LightmapBakeInput>(r.input)) {
    // The lightmap bake names the texture (or the environment) whose bytes do not decode; a scene with nothing to
    // bake is the whole job's.
    const std::string text = e.what();
    for (const BlobRef& ref : r.inputs) {
      if (ref.field.find(".textures[") != std::string::npos) {
        const std::size_t i = std::stoul(ref.field.substr(ref.field.find('[') + 1));
        const std::string& name = r.lightmap().textures.size() > i ? r.lightmap().textures[i].name : std::string();
        if (!name.empty() && text.find(name) != std::string::npos) return InvalidField(ref.field, text);
      } else if (ref.field.find(".environment.") != std::string::npos &&
                 text.find("environment") != std::string::npos) {
        return InvalidField(ref.field, text);
      }
    }
    return InvalidField(prefix, text);
  }
  if (!r.inputs.empty()) {
    field = r.inputs.size() == 1 ? r.inputs[0].field : prefix + ".faces";
  }
  return InvalidField(field, e.what());
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

std::string cache_key(const BakeRequest& request, const std::string& baker_version) {
  return proto::sha256_hex(canonical_text(request) + "baker=" + baker_version + "\n");
}

}  // namespace kiln::daemon
