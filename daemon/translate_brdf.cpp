// The BRDF models of the translation layer: a kiln.v1 model message in, a brdf::ModelSpec (or a two-lobe
// brdf::MaterialSpec) out, every parameter checked and named by its path ("job.material.ggx.alpha").
#include <string>

#include "daemon/translate_fields.h"
#include "proto/kiln.pb.h"

namespace kiln::daemon::detail {
namespace {

brdf::FresnelMode fresnel(kiln::v1::Fresnel f, const std::string& field, std::optional<brdf::FresnelMode>& out) {
  switch (f) {
    case kiln::v1::FRESNEL_DEFAULT:
      out.reset();
      return brdf::FresnelMode::none;
    case kiln::v1::FRESNEL_NONE:
      out = brdf::FresnelMode::none;
      return *out;
    case kiln::v1::FRESNEL_SCHLICK:
      out = brdf::FresnelMode::schlick;
      return *out;
    case kiln::v1::FRESNEL_EXACT:
      out = brdf::FresnelMode::exact;
      return *out;
    default:
      throw InvalidField(field, "unknown value " + std::to_string(static_cast<int>(f)));
  }
}

// Either one isotropic alpha or the pair alpha_x, alpha_y.
void microfacet_roughness(const kiln::v1::Microfacet& m, const std::string& path, brdf::ModelSpec& s) {
  if (m.has_alpha() && (m.has_alpha_x() || m.has_alpha_y())) {
    throw InvalidField(path + ".alpha", "give either alpha or alpha_x and alpha_y, not both");
  }
  if (m.has_alpha_x() != m.has_alpha_y()) {
    throw InvalidField(path + (m.has_alpha_x() ? ".alpha_y" : ".alpha_x"), "alpha_x and alpha_y go together");
  }
  if (m.has_alpha()) {
    check_range(path + ".alpha", m.alpha(), bounds::kAlpha);
    s.alpha_x = s.alpha_y = m.alpha();
  } else if (m.has_alpha_x()) {
    check_range(path + ".alpha_x", m.alpha_x(), bounds::kAlpha);
    check_range(path + ".alpha_y", m.alpha_y(), bounds::kAlpha);
    s.alpha_x = m.alpha_x();
    s.alpha_y = m.alpha_y();
  }
}

// The distribution, masking and normalization choices; DEFAULT leaves the model's own.
void microfacet_terms(const kiln::v1::Microfacet& m, const std::string& path, brdf::ModelSpec& s) {
  switch (m.distribution()) {
    case kiln::v1::DISTRIBUTION_DEFAULT:
      break;
    case kiln::v1::DISTRIBUTION_GGX:
      s.distribution = brdf::Distribution::ggx;
      break;
    case kiln::v1::DISTRIBUTION_BECKMANN:
      s.distribution = brdf::Distribution::beckmann;
      break;
    case kiln::v1::DISTRIBUTION_SCHLICK_BECKMANN:
      s.distribution = brdf::Distribution::schlick_beckmann;
      break;
    default:
      throw InvalidField(path + ".distribution", "unknown value " + std::to_string(m.distribution()));
  }
  switch (m.masking()) {
    case kiln::v1::MASKING_DEFAULT:
      break;
    case kiln::v1::MASKING_SEPARABLE:
      s.masking = brdf::Masking::separable;
      break;
    case kiln::v1::MASKING_HEIGHT_CORRELATED:
      s.masking = brdf::Masking::height_correlated;
      break;
    case kiln::v1::MASKING_V_GROOVE:
      s.masking = brdf::Masking::v_groove;
      break;
    case kiln::v1::MASKING_SCHLICK:
      s.masking = brdf::Masking::schlick;
      break;
    default:
      throw InvalidField(path + ".masking", "unknown value " + std::to_string(m.masking()));
  }
  switch (m.normalization()) {
    case kiln::v1::NORMALIZATION_DEFAULT:
    case kiln::v1::NORMALIZATION_FOUR:
      s.normalization = brdf::Normalization::four;
      break;
    case kiln::v1::NORMALIZATION_PI:
      s.normalization = brdf::Normalization::pi;
      break;
    default:
      throw InvalidField(path + ".normalization", "unknown value " + std::to_string(m.normalization()));
  }
}

void microfacet(const kiln::v1::Microfacet& m, const std::string& path, brdf::ModelSpec& s) {
  microfacet_roughness(m, path, s);
  fresnel(m.fresnel(), path + ".fresnel", s.fresnel);
  if (m.has_f0()) s.f0 = color(m.f0(), path + ".f0", bounds::kReflectance);
  if (m.has_eta()) {
    check_range(path + ".eta", m.eta(), bounds::kEta);
    s.eta = m.eta();
  }
  microfacet_terms(m, path, s);
}

// The full model or its simple form; only the full one has the two-bounce term.
void oren_nayar(const kiln::v1::OrenNayar& on, bool full, const std::string& path, brdf::ModelSpec& s) {
  const std::string p = path + (full ? ".oren_nayar" : ".oren_nayar_simple");
  s.model = full ? brdf::Model::oren_nayar : brdf::Model::oren_nayar_simple;
  if (on.has_albedo()) s.albedo = color(on.albedo(), p + ".albedo", bounds::kReflectance);
  if (on.has_sigma()) {
    check_range(p + ".sigma", on.sigma(), bounds::kSigma);
    s.sigma = on.sigma();
  }
  if (on.interreflection() && !full) {
    throw InvalidField(p + ".interreflection", "the two-bounce term belongs to the full model (oren_nayar)");
  }
  s.interreflection = on.interreflection();
}

brdf::SchlickLayer schlick_layer(const kiln::v1::SchlickLayer& l, const std::string& path) {
  brdf::SchlickLayer out;
  if (l.has_c()) out.c = color(l.c(), path + ".c", bounds::kReflectance);
  if (l.has_r()) {
    check_range(path + ".r", l.r(), bounds::kSchlickParameter);
    out.r = l.r();
  }
  if (l.has_p()) {
    check_range(path + ".p", l.p(), bounds::kSchlickParameter);
    out.p = l.p();
  }
  return out;
}

// One BRDF model from a MaterialJob or a Brdf message: the two share their oneof's names and numbers.
template <class Message>
brdf::ModelSpec model(const Message& m, const std::string& path) {
  brdf::ModelSpec s;
  using MJ = Message;
  switch (m.model_case()) {
    case MJ::kLambert:
      s.model = brdf::Model::lambert;
      if (m.lambert().has_albedo())
        s.albedo = color(m.lambert().albedo(), path + ".lambert.albedo", bounds::kReflectance);
      break;
    case MJ::kOrenNayar:
      oren_nayar(m.oren_nayar(), true, path, s);
      break;
    case MJ::kOrenNayarSimple:
      oren_nayar(m.oren_nayar_simple(), false, path, s);
      break;
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
    default:  // MODEL_NOT_SET (a MaterialJob's layered case is translated by material_spec instead)
      throw InvalidField(path,
                         "no model given: set one of lambert, oren_nayar, oren_nayar_simple, cook_torrance, "
                         "ggx, beckmann, schlick, schlick_double");
  }
  // The bakers' own validation is the backstop: anything the checks above let through is still named.
  if (auto problem = brdf::validate(s)) throw baker_problem(path, *problem);
  return s;
}

}  // namespace

brdf::ModelSpec brdf_model(const kiln::v1::Brdf& m, const std::string& path) { return model(m, path); }

brdf::ModelSpec material_job_model(const kiln::v1::MaterialJob& m, const std::string& path) { return model(m, path); }

brdf::MaterialSpec material_spec(const kiln::v1::Layered& l, const std::string& path) {
  brdf::MaterialSpec spec;
  spec.diffuse.model = brdf::Model::lambert;
  if (l.has_diffuse()) spec.diffuse = model(l.diffuse(), path + ".diffuse");
  switch (l.combine()) {
    case kiln::v1::COMBINE_DEFAULT:
    case kiln::v1::COMBINE_LAYERED:
      spec.combine = brdf::Combine::layered;
      break;
    case kiln::v1::COMBINE_WEIGHTS:
      spec.combine = brdf::Combine::weights;
      break;
    default:
      throw InvalidField(path + ".combine", "unknown value " + std::to_string(l.combine()));
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
    check_range(path + ".specular_weight", l.specular_weight(), bounds::kSpecularWeight);
    spec.specular_weight = l.specular_weight();
  }
  if (auto problem = brdf::validate(spec)) throw baker_problem(path, *problem);
  return spec;
}

}  // namespace kiln::daemon::detail
