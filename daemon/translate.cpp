#include "daemon/translate.h"

#include <array>
#include <cmath>
#include <sstream>
#include <type_traits>

#include "bakers/bake/number_format.h"
#include "bakers/image/color.h"
#include "daemon/store/blob_store.h"
#include "daemon/translate_fields.h"
#include "proto/digest.h"
#include "proto/kiln.pb.h"

namespace kiln::daemon {

const char* const kBakerVersion = material::kMaterialBakerVersion;

using bake::format_number;

namespace {

using detail::baker_problem;
using detail::check_range;
using detail::color;
using detail::input_blob;

constexpr std::size_t kMaxNameBytes = 256;
constexpr std::size_t kMaxForcedEffects = 64;
constexpr std::size_t kMaxEffectNameBytes = 64;

brdf::FresnelMode fresnel(kiln::v1::Fresnel f, const std::string& field, std::optional<brdf::FresnelMode>& out) {
  switch (f) {
    case kiln::v1::FRESNEL_DEFAULT: out.reset(); return brdf::FresnelMode::none;
    case kiln::v1::FRESNEL_NONE: out = brdf::FresnelMode::none; return *out;
    case kiln::v1::FRESNEL_SCHLICK: out = brdf::FresnelMode::schlick; return *out;
    case kiln::v1::FRESNEL_EXACT: out = brdf::FresnelMode::exact; return *out;
    default: throw InvalidField(field, "unknown value " + std::to_string(static_cast<int>(f)));
  }
}

void microfacet(const kiln::v1::Microfacet& m, const std::string& path, brdf::ModelSpec& s) {
  if (m.has_alpha() && (m.has_alpha_x() || m.has_alpha_y())) {
    throw InvalidField(path + ".alpha", "give either alpha or alpha_x and alpha_y, not both");
  }
  if (m.has_alpha_x() != m.has_alpha_y()) {
    throw InvalidField(path + (m.has_alpha_x() ? ".alpha_y" : ".alpha_x"), "alpha_x and alpha_y go together");
  }
  if (m.has_alpha()) {
    check_range(path + ".alpha", m.alpha(), 0.0, 1.0, true);
    s.alpha_x = s.alpha_y = m.alpha();
  } else if (m.has_alpha_x()) {
    check_range(path + ".alpha_x", m.alpha_x(), 0.0, 1.0, true);
    check_range(path + ".alpha_y", m.alpha_y(), 0.0, 1.0, true);
    s.alpha_x = m.alpha_x();
    s.alpha_y = m.alpha_y();
  }
  fresnel(m.fresnel(), path + ".fresnel", s.fresnel);
  if (m.has_f0()) s.f0 = color(m.f0(), path + ".f0", 0.0, 1.0);
  if (m.has_eta()) {
    check_range(path + ".eta", m.eta(), 0.1, 10.0, false);
    s.eta = m.eta();
  }
  switch (m.distribution()) {
    case kiln::v1::DISTRIBUTION_DEFAULT: break;
    case kiln::v1::DISTRIBUTION_GGX: s.distribution = brdf::Distribution::ggx; break;
    case kiln::v1::DISTRIBUTION_BECKMANN: s.distribution = brdf::Distribution::beckmann; break;
    case kiln::v1::DISTRIBUTION_SCHLICK_BECKMANN: s.distribution = brdf::Distribution::schlick_beckmann; break;
    default: throw InvalidField(path + ".distribution", "unknown value " + std::to_string(m.distribution()));
  }
  switch (m.masking()) {
    case kiln::v1::MASKING_DEFAULT: break;
    case kiln::v1::MASKING_SEPARABLE: s.masking = brdf::Masking::separable; break;
    case kiln::v1::MASKING_HEIGHT_CORRELATED: s.masking = brdf::Masking::height_correlated; break;
    case kiln::v1::MASKING_V_GROOVE: s.masking = brdf::Masking::v_groove; break;
    case kiln::v1::MASKING_SCHLICK: s.masking = brdf::Masking::schlick; break;
    default: throw InvalidField(path + ".masking", "unknown value " + std::to_string(m.masking()));
  }
  switch (m.normalization()) {
    case kiln::v1::NORMALIZATION_DEFAULT:
    case kiln::v1::NORMALIZATION_FOUR: s.normalization = brdf::Normalization::four; break;
    case kiln::v1::NORMALIZATION_PI: s.normalization = brdf::Normalization::pi; break;
    default: throw InvalidField(path + ".normalization", "unknown value " + std::to_string(m.normalization()));
  }
}

brdf::SchlickLayer schlick_layer(const kiln::v1::SchlickLayer& l, const std::string& path) {
  brdf::SchlickLayer out;
  if (l.has_c()) out.c = color(l.c(), path + ".c", 0.0, 1.0);
  if (l.has_r()) {
    check_range(path + ".r", l.r(), 0.0, 1.0, false);
    out.r = l.r();
  }
  if (l.has_p()) {
    check_range(path + ".p", l.p(), 0.0, 1.0, false);
    out.p = l.p();
  }
  return out;
}

// One BRDF model from a MaterialJob or a Brdf message: the two share their oneof's names and numbers.
template <class Message>
brdf::ModelSpec model(const Message& m, const std::string& path) {
  brdf::ModelSpec s;
  using MJ = Message;
  if constexpr (std::is_same_v<Message, kiln::v1::MaterialJob>) {
    if (m.model_case() == MJ::kLayered) {
      throw InvalidField(path + ".layered", "two-lobe materials are not supported by the material bake yet; "
                                            "bake the diffuse and the specular model as two jobs");
    }
  }
  switch (m.model_case()) {
    case MJ::kLambert:
      s.model = brdf::Model::lambert;
      if (m.lambert().has_albedo()) s.albedo = color(m.lambert().albedo(), path + ".lambert.albedo", 0.0, 1.0);
      break;
    case MJ::kOrenNayar:
    case MJ::kOrenNayarSimple: {
      const bool full = m.model_case() == MJ::kOrenNayar;
      const auto& on = full ? m.oren_nayar() : m.oren_nayar_simple();
      const std::string p = path + (full ? ".oren_nayar" : ".oren_nayar_simple");
      s.model = full ? brdf::Model::oren_nayar : brdf::Model::oren_nayar_simple;
      if (on.has_albedo()) s.albedo = color(on.albedo(), p + ".albedo", 0.0, 1.0);
      if (on.has_sigma()) {
        check_range(p + ".sigma", on.sigma(), 0.0, 1.5707963267948966, false);
        s.sigma = on.sigma();
      }
      if (on.interreflection() && !full) {
        throw InvalidField(p + ".interreflection", "the two-bounce term belongs to the full model (oren_nayar)");
      }
      s.interreflection = on.interreflection();
      break;
    }
    case MJ::kCookTorrance:
      s.model = brdf::Model::cook_torrance;
      microfacet(m.cook_torrance(), path + ".cook_torrance", s);
      break;
    case MJ::kGgx:
      s.model = brdf::Model::ggx;
      microfacet(m.ggx(), path + ".ggx", s);
      break;
    case MJ::kBeckmann:
      s.model = brdf::Model::beckmann;
      microfacet(m.beckmann(), path + ".beckmann", s);
      break;
    case MJ::kSchlick:
      s.model = brdf::Model::schlick;
      s.layer = schlick_layer(m.schlick(), path + ".schlick");
      break;
    case MJ::kSchlickDouble:
      s.model = brdf::Model::schlick_double;
      s.layer = schlick_layer(m.schlick_double().top(), path + ".schlick_double.top");
      s.bottom_layer = schlick_layer(m.schlick_double().bottom(), path + ".schlick_double.bottom");
      break;
    default:  // MODEL_NOT_SET (and MaterialJob's layered, refused above)
      throw InvalidField(path, "no model given: set one of lambert, oren_nayar, oren_nayar_simple, cook_torrance, "
                               "ggx, beckmann, schlick, schlick_double");
  }
  // The bakers' own validation is the backstop: anything the checks above let through is still named.
  if (auto problem = brdf::validate(s)) throw baker_problem(path, *problem);
  return s;
}

void translate_material(const kiln::v1::JobSpec& spec, BakeRequest& r) {
  r.type = "material";
  const kiln::v1::MaterialJob& m = spec.material();
  material::MaterialBakeInput& in = r.material;
  in.model = model(m, "job.material");
  if (m.has_table_mu()) {
    check_range("job.material.table_mu", m.table_mu(), 2, 1024, false);
    in.table_mu = static_cast<int>(m.table_mu());
  }
  if (m.has_table_roughness()) {
    check_range("job.material.table_roughness", m.table_roughness(), 2, 1024, false);
    in.table_roughness = static_cast<int>(m.table_roughness());
  }
  in.merl = m.merl();
  // The material bake has one optional effect: the MERL table. Forcing it overrides `merl`.
  for (const auto& [effect, on] : spec.force_effects()) {
    const std::string field = "job.force_effects[" + effect.substr(0, kMaxEffectNameBytes) + "]";
    if (effect.size() > kMaxEffectNameBytes) throw InvalidField(field, "effect names are at most 64 bytes");
    if (effect != "merl") throw InvalidField(field, "unknown effect for a material bake; known: merl");
    in.merl = on;
  }
  const kiln::v1::Quality& q = spec.quality();
  if (q.has_samples()) {
    check_range("job.quality.samples", static_cast<double>(q.samples()), 1, double(1 << 24), false);
    in.samples = q.samples();
  }
  if (q.has_target_error()) {
    check_range("job.quality.target_error", q.target_error(), 0.0, 1.0, true);
    in.target_error = q.target_error();
  }
  if (q.has_time_limit_seconds()) {
    check_range("job.quality.time_limit_seconds", q.time_limit_seconds(), 0.0, 86400.0, true);
    in.time_limit_seconds = q.time_limit_seconds();
  }
  in.seed = q.seed();
  if (auto problem = material::validate(in)) throw baker_problem("job.material", *problem);
}

constexpr std::size_t kMaxColorSpaceBytes = 64;

// Every level down to 4x4: the baker's default and its largest count.
int most_levels(int size) {
  int levels = 1;
  while ((size >> levels) >= 4) ++levels;
  return levels;
}
constexpr std::array<const char*, 6> kFaceLabels = {"+X", "-X", "+Y", "-Y", "+Z", "-Z"};

void translate_environment(const kiln::v1::JobSpec& spec, const store::BlobStore* blobs, BakeRequest& r) {
  r.type = "environment";
  const std::string path = "job.environment";
  const kiln::v1::EnvironmentJob& e = spec.environment();
  envmap::EnvironmentBakeInput& in = r.environment;
  using EJ = kiln::v1::EnvironmentJob;
  switch (e.source_case()) {
    case EJ::kImage:
      r.inputs.push_back(input_blob(e.image(), path + ".image", blobs));
      break;
    case EJ::kFaces: {
      const int n = e.faces().digests_size();
      if (n != 6) {
        throw InvalidField(path + ".faces.digests", "exactly six faces (+X, -X, +Y, -Y, +Z, -Z), got " +
                                                        std::to_string(n));
      }
      for (int i = 0; i < n; ++i) {
        r.inputs.push_back(
            input_blob(e.faces().digests(i), path + ".faces.digests[" + std::to_string(i) + "]", blobs));
      }
      break;
    }
    case EJ::kConstant:
      in.constant = color(e.constant(), path + ".constant", 0.0, 1e6);
      break;
    case EJ::SOURCE_NOT_SET:
      throw InvalidField(path, "no environment given: set image (an uploaded equirectangular image), faces (six "
                               "uploaded cube faces) or constant (a colour)");
  }
  const bool constant = e.source_case() == EJ::kConstant;
  auto image_only = [&](const char* name) {
    throw InvalidField(path + "." + name, "applies to an image or faces; a constant colour is already radiance in "
                                          "the working space: leave it out");
  };
  if (!e.color_space().empty()) {
    if (constant) image_only("color_space");
    detail::check_color_space(e.color_space(), path + ".color_space");
    in.decode.color_space = e.color_space();
  }
  if (e.has_rotation_degrees()) {
    if (constant) image_only("rotation_degrees");
    check_range(path + ".rotation_degrees", e.rotation_degrees(), -360.0, 360.0, false);
    in.decode.rotation_degrees = e.rotation_degrees();
  }
  if (e.has_intensity()) {
    if (constant) image_only("intensity");
    check_range(path + ".intensity", e.intensity(), 0.0, envmap::kMaxEnvIntensity, true);
    in.decode.intensity = e.intensity();
  }
  switch (e.lobe()) {
    case kiln::v1::ENVIRONMENT_LOBE_DEFAULT:
    case kiln::v1::ENVIRONMENT_LOBE_GGX: in.lobe = envmap::EnvLobe::ggx; break;
    case kiln::v1::ENVIRONMENT_LOBE_BECKMANN: in.lobe = envmap::EnvLobe::beckmann; break;
    case kiln::v1::ENVIRONMENT_LOBE_COOK_TORRANCE: in.lobe = envmap::EnvLobe::cook_torrance; break;
    case kiln::v1::ENVIRONMENT_LOBE_SCHLICK: in.lobe = envmap::EnvLobe::schlick; break;
    default: throw InvalidField(path + ".lobe", "unknown value " + std::to_string(static_cast<int>(e.lobe())));
  }
  if (e.has_size()) {
    const uint32_t n = e.size();
    if (n < 4 || n > 2048 || (n & (n - 1)) != 0) {
      throw InvalidField(path + ".size", "must be a power of two in [4, 2048], got " + std::to_string(n));
    }
    in.size = static_cast<int>(n);
  }
  if (e.has_levels()) {
    check_range(path + ".levels", e.levels(), 1, most_levels(in.size), false);
    in.levels = static_cast<int>(e.levels());
  }
  if (e.has_irradiance_size()) {
    check_range(path + ".irradiance_size", e.irradiance_size(), 1, 256, false);
    in.irradiance_size = static_cast<int>(e.irradiance_size());
  }
  if (e.has_dfg_size()) {
    check_range(path + ".dfg_size", e.dfg_size(), 2, 1024, false);
    in.dfg_size = static_cast<int>(e.dfg_size());
  }
  if (e.has_dfg_samples()) {
    check_range(path + ".dfg_samples", e.dfg_samples(), 16, double(1 << 20), false);
    in.dfg_samples = static_cast<int>(e.dfg_samples());
  }
  if (e.has_preview()) in.preview = e.preview();

  const kiln::v1::Quality& q = spec.quality();
  if (q.has_samples()) {
    check_range("job.quality.samples", static_cast<double>(q.samples()), 4, 65536, false);
    in.samples = static_cast<int>(q.samples());
  }
  if (q.has_target_error()) {
    check_range("job.quality.target_error", q.target_error(), 1e-4, 1.0, false);
    in.target_error = q.target_error();
  }
  if (q.has_time_limit_seconds()) {
    throw InvalidField("job.quality.time_limit_seconds", "not supported by the environment bake; bound its cost "
                                                         "with samples or target_error");
  }
  in.seed = q.seed();
  for (const auto& [effect, on] : spec.force_effects()) {
    if (effect.empty() || effect.size() > kMaxEffectNameBytes) {
      throw InvalidField("job.force_effects[" + effect.substr(0, kMaxEffectNameBytes) + "]",
                         "effect names are 1 to 64 bytes, got " + std::to_string(effect.size()));
    }
    in.force_effects[effect] = on;
  }
  // The baker's own validation is the backstop (and knows the effects its planner decides). The bytes are not
  // read yet: stand-ins show it the source's shape, which is all it checks before decoding.
  envmap::EnvironmentBakeInput probe = in;
  if (e.source_case() == EJ::kImage) probe.image = "(uploaded image)";
  if (e.source_case() == EJ::kFaces) probe.faces.assign(r.inputs.size(), "(uploaded face)");
  if (auto problem = envmap::validate(probe)) {
    // Forced effects, sources and samples live elsewhere in the spec than in the baker's input.
    const std::string& field = problem->field();
    if (field.rfind("force_effects", 0) == 0) throw baker_problem("job", *problem);
    if (field == "samples" || field == "target_error" || field == "seed") throw baker_problem("job.quality", *problem);
    if (field == "image" && !r.inputs.empty()) throw InvalidField(r.inputs[0].field, problem->problem());
    throw baker_problem(path, *problem);
  }
}

}  // namespace

namespace detail {

void check_range(const std::string& field, double v, double lo, double hi, bool lo_open) {
  const bool ok = std::isfinite(v) && (lo_open ? v > lo : v >= lo) && v <= hi;
  if (!ok) {
    throw InvalidField(field, std::string("must be in ") + (lo_open ? "(" : "[") + format_number(lo) + ", " +
                                  format_number(hi) + "], got " + format_number(v));
  }
}

Rgb color(const kiln::v1::Color& c, const std::string& field, double lo, double hi) {
  check_range(field + ".r", c.r(), lo, hi, false);
  check_range(field + ".g", c.g(), lo, hi, false);
  check_range(field + ".b", c.b(), lo, hi, false);
  return Rgb{c.r(), c.g(), c.b()};
}

InvalidField baker_problem(const std::string& prefix, const bake::InvalidInput& problem) {
  return InvalidField(problem.field().empty() ? prefix : prefix + "." + problem.field(), problem.problem());
}

// An input blob's digest: well formed, within kMaxInputBlobBytes and, when a store is given, stored whole.
BlobRef input_blob(const kiln::v1::Digest& d, const std::string& field, const store::BlobStore* blobs) {
  if (!proto::is_valid_sha256_hex(d.sha256())) {
    throw InvalidField(field + ".sha256", "must be 64 lowercase hex digits, got '" + d.sha256().substr(0, 80) + "'");
  }
  if (d.size() == 0) throw InvalidField(field + ".size", "an input (image or mesh) is not empty; got a blob of 0 bytes");
  if (d.size() > kMaxInputBlobBytes) {
    throw InvalidField(field + ".size", "an input blob is at most " + std::to_string(kMaxInputBlobBytes >> 20) +
                                            " MiB, got " + std::to_string(d.size()) +
                                            " bytes; scale an image down (16384 x 8192 RGB half EXR is ~400 MiB), "
                                            "split a mesh");
  }
  if (blobs && !blobs->contains(store::BlobId{d.sha256(), d.size()})) {
    throw InvalidField(field, "blob " + d.sha256() + " (" + std::to_string(d.size()) +
                                  " bytes) is not in the server's store; upload it (BlobPut) before submitting");
  }
  return BlobRef{field, d.sha256(), d.size()};
}

void check_color_space(const std::string& name, const std::string& field) {
  if (name.size() > kMaxColorSpaceBytes) {
    throw InvalidField(field, "at most 64 bytes, got " + std::to_string(name.size()));
  }
  const image::ColorConfig& config = image::ColorConfig::active();
  if (!config.has_space(name)) {
    std::string known;
    for (const std::string& space : config.spaces()) known += (known.empty() ? "" : ", ") + space;
    throw InvalidField(field, "'" + name + "' is not a colour space or role of " + config.source() + "; known: " +
                                  known);
  }
}

std::string read_input(const BlobRef& ref, store::BlobStore& blobs) {
  const store::BlobId id{ref.sha256, ref.size};
  if (!blobs.contains(id)) {
    throw InvalidField(ref.field, "blob " + ref.sha256 + " is no longer in the server's store (removed by its "
                                  "retention limit); upload it again and resubmit the job");
  }
  return blobs.read(id);  // verified against the digest
}

brdf::ModelSpec brdf_model(const kiln::v1::Brdf& m, const std::string& path) { return model(m, path); }

brdf::MaterialSpec material_spec(const kiln::v1::Layered& l, const std::string& path) {
  brdf::MaterialSpec spec;
  spec.diffuse.model = brdf::Model::lambert;
  if (l.has_diffuse()) spec.diffuse = model(l.diffuse(), path + ".diffuse");
  switch (l.combine()) {
    case kiln::v1::COMBINE_DEFAULT:
    case kiln::v1::COMBINE_LAYERED: spec.combine = brdf::Combine::layered; break;
    case kiln::v1::COMBINE_WEIGHTS: spec.combine = brdf::Combine::weights; break;
    default: throw InvalidField(path + ".combine", "unknown value " + std::to_string(l.combine()));
  }
  if (l.has_specular()) {
    spec.specular = model(l.specular(), path + ".specular");
  } else {
    // No specular lobe: a weightless one, so that the material is exactly its diffuse lobe.
    spec.specular.model = brdf::Model::lambert;
    spec.combine = brdf::Combine::weights;
    spec.specular_weight = 0;
  }
  if (l.has_specular_weight()) {
    if (spec.combine != brdf::Combine::weights) {
      throw InvalidField(path + ".specular_weight", "applies to combine COMBINE_WEIGHTS only");
    }
    check_range(path + ".specular_weight", l.specular_weight(), 0.0, 1.0, false);
    spec.specular_weight = l.specular_weight();
  }
  if (auto problem = brdf::validate(spec)) throw baker_problem(path, *problem);
  return spec;
}

}  // namespace detail

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
    case kiln::v1::JobSpec::kMaterial: translate_material(spec, r); break;
    case kiln::v1::JobSpec::kEnvironment: translate_environment(spec, blobs, r); break;
    case kiln::v1::JobSpec::kLightmap: detail::translate_lightmap(spec, blobs, r); break;
    default: throw InvalidField("job", "no job given: set material, environment or lightmap");
  }
  return r;
}

void load_inputs(BakeRequest& r, store::BlobStore& blobs) {
  if (r.type == "lightmap") return detail::load_lightmap_inputs(r, blobs);
  if (r.type != "environment") return;
  envmap::EnvironmentBakeInput& in = r.environment;
  in.image.clear();
  in.faces.clear();
  for (const BlobRef& ref : r.inputs) {
    std::string bytes = detail::read_input(ref, blobs);
    if (ref.field.find(".faces.") != std::string::npos) {
      in.faces.push_back(std::move(bytes));
    } else {
      in.image = std::move(bytes);
    }
  }
}

InvalidField input_error(const BakeRequest& r, const std::exception& e) {
  const std::string prefix = "job." + r.type;
  if (const auto* problem = dynamic_cast<const bake::InvalidInput*>(&e)) return baker_problem(prefix, *problem);
  // Anything else the bakers raise about their input concerns the bytes they decode.
  std::string field = prefix;
  if (r.type == "lightmap") {
    // The lightmap bake names the texture (or the environment) whose bytes do not decode; a scene with nothing to
    // bake is the whole job's.
    const std::string text = e.what();
    for (const BlobRef& ref : r.inputs) {
      if (ref.field.find(".textures[") != std::string::npos) {
        const std::size_t i = std::stoul(ref.field.substr(ref.field.find('[') + 1));
        const std::string& name = r.lightmap.textures.size() > i ? r.lightmap.textures[i].name : std::string();
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
  if (r.type == "lightmap") return lightmap::kLightmapBakerVersion;
  return r.type == "environment" ? envmap::kEnvironmentBakerVersion : material::kMaterialBakerVersion;
}

namespace {

// The environment bake's settings, defaults applied; its input blobs by digest (their bytes are named by it).
std::string environment_canonical_text(const BakeRequest& r) {
  const envmap::EnvironmentBakeInput& in = r.environment;
  std::ostringstream o;
  o << "type=" << r.type << "\nsource=";
  if (in.constant) {
    o << "constant:" << format_number(in.constant->r) << "," << format_number(in.constant->g) << ","
      << format_number(in.constant->b);
  } else {
    o << (r.inputs.size() == 1 ? "image" : "faces");
    for (const BlobRef& b : r.inputs) o << ":" << b.sha256 << "/" << b.size;
  }
  // An empty colour space is the format's default, which the same bytes always decode to.
  o << "\ncolor_space=" << (in.decode.color_space.empty() ? "(format default)" : in.decode.color_space)
    << "\nrotation_degrees=" << format_number(in.decode.rotation_degrees)
    << "\nintensity=" << format_number(in.decode.intensity) << "\nlobe=" << envmap::to_string(in.lobe)
    << "\nsize=" << in.size << "\nlevels=" << (in.levels != 0 ? in.levels : most_levels(in.size)) << "\nirradiance_size=" << in.irradiance_size
    << "\ndfg_size=" << in.dfg_size << "\ndfg_samples=" << in.dfg_samples << "\nsamples=" << in.samples
    << "\ntarget_error=" << format_number(in.target_error) << "\npreview=" << in.preview << "\nseed=" << in.seed
    << "\nforce_effects=";
  for (const auto& [effect, on] : in.force_effects) o << effect << (on ? "+" : "-") << ";";  // sorted by name
  o << "\n";
  return o.str();
}

}  // namespace

std::string canonical_text(const BakeRequest& r) {
  if (r.type == "environment") return environment_canonical_text(r);
  if (r.type == "lightmap") return detail::lightmap_canonical_text(r);
  const material::MaterialBakeInput& in = r.material;
  const brdf::ModelSpec& s = in.model;
  std::ostringstream o;
  auto rgb = [](const Rgb& c) { return format_number(c.r) + "," + format_number(c.g) + "," + format_number(c.b); };
  o << "type=" << r.type << "\nmodel=" << brdf::to_string(s.model) << "\nalbedo=" << rgb(s.albedo)
    << "\nsigma=" << format_number(s.sigma) << "\ninterreflection=" << s.interreflection
    << "\nalpha_x=" << format_number(s.alpha_x) << "\nalpha_y=" << format_number(s.alpha_y)
    << "\nfresnel=" << brdf::to_string(brdf::fresnel_mode(s)) << "\nf0=" << rgb(s.f0)
    << "\neta=" << format_number(s.eta)
    << "\ndistribution=" << (s.distribution ? brdf::to_string(*s.distribution) : "default")
    << "\nmasking=" << (s.masking ? brdf::to_string(*s.masking) : "default")
    << "\nnormalization=" << brdf::to_string(s.normalization) << "\nlayer=" << rgb(s.layer.c) << ","
    << format_number(s.layer.r) << "," << format_number(s.layer.p) << "\nbottom=" << rgb(s.bottom_layer.c) << ","
    << format_number(s.bottom_layer.r) << "," << format_number(s.bottom_layer.p) << "\ntable_mu=" << in.table_mu
    << "\ntable_roughness=" << in.table_roughness << "\nmerl=" << in.merl << "\nsamples=" << in.samples
    << "\ntarget_error=" << format_number(in.target_error)
    << "\ntime_limit_seconds=" << format_number(in.time_limit_seconds) << "\nseed=" << in.seed << "\n";
  return o.str();
}

std::string cache_key(const BakeRequest& request, const std::string& baker_version) {
  return proto::sha256_hex(canonical_text(request) + "baker=" + baker_version + "\n");
}

}  // namespace kiln::daemon
