#include "daemon/translate.h"

#include <cmath>
#include <sstream>

#include "bakers/brdf/describe.h"
#include "proto/digest.h"
#include "proto/kiln.pb.h"

namespace kiln::daemon {

const char* const kBakerVersion = material::kMaterialBakerVersion;

namespace {

using brdf::format_number;

constexpr std::size_t kMaxNameBytes = 256;
constexpr std::size_t kMaxForcedEffects = 64;
constexpr std::size_t kMaxEffectNameBytes = 64;

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

brdf::ModelSpec model(const kiln::v1::MaterialJob& m, const std::string& path) {
  brdf::ModelSpec s;
  using MJ = kiln::v1::MaterialJob;
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
    case MJ::kLayered:
      throw InvalidField(path + ".layered", "two-lobe materials are not supported by the material bake yet; "
                                            "bake the diffuse and the specular model as two jobs");
    case MJ::MODEL_NOT_SET:
      throw InvalidField(path, "no model given: set one of lambert, oren_nayar, oren_nayar_simple, cook_torrance, "
                               "ggx, beckmann, schlick, schlick_double");
  }
  // The bakers' own validation is the backstop: anything the checks above let through is still named.
  if (auto problem = brdf::validate(s)) {
    const std::string text = *problem;
    const auto colon = text.find(':');
    const std::string field = colon == std::string::npos ? path : path + "." + text.substr(0, colon);
    throw InvalidField(field, colon == std::string::npos ? text : text.substr(colon + 2));
  }
  return s;
}

}  // namespace

BakeRequest translate(const kiln::v1::JobSpec& spec) {
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
  if (spec.job_case() != kiln::v1::JobSpec::kMaterial) {
    throw InvalidField("job", "no job given: set material");
  }
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
  if (auto problem = material::validate(in)) {
    const std::string text = *problem;
    const auto colon = text.find(':');
    throw InvalidField("job.material." + text.substr(0, colon), colon == std::string::npos ? text : text.substr(colon + 2));
  }
  return r;
}

std::string canonical_text(const BakeRequest& r) {
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
