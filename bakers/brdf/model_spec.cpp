#include "bakers/brdf/model_spec.h"

#include <array>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "bakers/bake/number_format.h"
#include "bakers/bake/range_check.h"
#include "bakers/brdf/lambert.h"
#include "bakers/brdf/microfacet.h"
#include "bakers/brdf/oren_nayar.h"
#include "bakers/brdf/schlick.h"
#include "bakers/math/constants.h"

namespace kiln::brdf {
namespace {

// Each enum's names in one table, so to_string, parsing and the lists in messages cannot disagree.
template <typename E, size_t N>
using Names = std::array<std::pair<E, const char*>, N>;

constexpr Names<Model, 8> kModelNames{{{Model::lambert, "lambert"},
                                       {Model::oren_nayar, "oren-nayar"},
                                       {Model::oren_nayar_simple, "oren-nayar-simple"},
                                       {Model::cook_torrance, "cook-torrance"},
                                       {Model::ggx, "ggx"},
                                       {Model::beckmann, "beckmann"},
                                       {Model::schlick, "schlick"},
                                       {Model::schlick_double, "schlick-double"}}};
constexpr Names<FresnelMode, 3> kFresnelNames{
    {{FresnelMode::none, "none"}, {FresnelMode::schlick, "schlick"}, {FresnelMode::exact, "exact"}}};
constexpr Names<Distribution, 3> kDistributionNames{{{Distribution::ggx, "ggx"},
                                                     {Distribution::beckmann, "beckmann"},
                                                     {Distribution::schlick_beckmann, "schlick-beckmann"}}};
constexpr Names<Masking, 4> kMaskingNames{{{Masking::separable, "separable"},
                                           {Masking::height_correlated, "height-correlated"},
                                           {Masking::v_groove, "v-groove"},
                                           {Masking::schlick, "schlick"}}};
constexpr Names<Normalization, 2> kNormalizationNames{{{Normalization::four, "4"}, {Normalization::pi, "pi"}}};

template <typename E, size_t N>
std::string name_of(const Names<E, N>& names, E e) {
  for (const auto& [value, name] : names)
    if (value == e) return name;
  return "?";
}
template <typename E, size_t N>
std::optional<E> parse(const Names<E, N>& names, const std::string& s) {
  for (const auto& [value, name] : names)
    if (s == name) return value;
  return std::nullopt;
}
template <typename E, size_t N>
std::string all_names(const Names<E, N>& names) {
  std::string out;
  for (const auto& [value, name] : names) out += (out.empty() ? "" : "|") + std::string(name);
  return out;
}

bool is_microfacet(Model m) { return m == Model::cook_torrance || m == Model::ggx || m == Model::beckmann; }

using bake::check_range;
using bake::check_rgb;

std::optional<bake::InvalidInput> check_layer(const std::string& prefix, const SchlickLayer& l) {
  if (auto e = check_rgb(prefix + "c", l.c, bounds::kReflectance)) return e;
  if (auto e = check_range(prefix + "r", l.r, bounds::kSchlickParameter)) return e;
  return check_range(prefix + "p", l.p, bounds::kSchlickParameter);
}

}  // namespace

std::string to_string(Model m) { return name_of(kModelNames, m); }
std::string to_string(FresnelMode m) { return name_of(kFresnelNames, m); }
std::string to_string(Distribution d) { return name_of(kDistributionNames, d); }
std::string to_string(Masking m) { return name_of(kMaskingNames, m); }
std::string to_string(Normalization n) { return name_of(kNormalizationNames, n); }
std::optional<Model> model_from_string(const std::string& s) { return parse(kModelNames, s); }
std::optional<FresnelMode> fresnel_from_string(const std::string& s) { return parse(kFresnelNames, s); }
std::optional<Distribution> distribution_from_string(const std::string& s) { return parse(kDistributionNames, s); }
std::optional<Masking> masking_from_string(const std::string& s) { return parse(kMaskingNames, s); }
std::optional<Normalization> normalization_from_string(const std::string& s) { return parse(kNormalizationNames, s); }
std::string model_names() { return all_names(kModelNames); }
std::string fresnel_names() { return all_names(kFresnelNames); }
std::string distribution_names() { return all_names(kDistributionNames); }
std::string masking_names() { return all_names(kMaskingNames); }
std::string normalization_names() { return all_names(kNormalizationNames); }

FresnelMode fresnel_mode(const ModelSpec& spec) {
  return spec.fresnel.value_or(spec.model == Model::cook_torrance ? FresnelMode::exact : FresnelMode::none);
}

std::optional<bake::InvalidInput> validate(const ModelSpec& spec) {
  switch (spec.model) {
    case Model::lambert:
      return check_rgb("albedo", spec.albedo, bounds::kReflectance);
    case Model::oren_nayar:
    case Model::oren_nayar_simple:
      if (auto e = check_rgb("albedo", spec.albedo, bounds::kReflectance)) return e;
      // Oren & Nayar's fits were made for σ up to about 40° and slopes beyond 90° mean nothing.
      return check_range("sigma", spec.sigma, bounds::kSigma);
    case Model::cook_torrance:
    case Model::ggx:
    case Model::beckmann:
      if (auto e = check_range("alpha_x", spec.alpha_x, bounds::kAlpha)) return e;
      if (auto e = check_range("alpha_y", spec.alpha_y, bounds::kAlpha)) return e;
      if (fresnel_mode(spec) == FresnelMode::schlick) {
        if (auto e = check_rgb("f0", spec.f0, bounds::kReflectance)) return e;
      }
      if (fresnel_mode(spec) == FresnelMode::exact) {
        // Dielectric interfaces: 0.1 and 10 are far beyond any real pair of media (diamond in air is 2.42).
        if (auto e = check_range("eta", spec.eta, bounds::kEta)) return e;
      }
      return std::nullopt;
    case Model::schlick:
      return check_layer("", spec.layer);
    case Model::schlick_double:
      if (auto e = check_layer("top.", spec.layer)) return e;
      return check_layer("bottom.", spec.bottom_layer);
  }
  return bake::InvalidInput("model", "unknown model");
}

std::unique_ptr<Bxdf> make_bxdf(const ModelSpec& spec) {
  if (auto error = validate(spec)) throw *error;
  switch (spec.model) {
    case Model::lambert:
      return std::make_unique<Lambert>(spec.albedo);
    case Model::oren_nayar:
      return std::make_unique<OrenNayar>(spec.albedo, spec.sigma, spec.interreflection);
    case Model::oren_nayar_simple:
      return std::make_unique<OrenNayarSimple>(spec.albedo, spec.sigma);
    case Model::cook_torrance:
    case Model::ggx:
    case Model::beckmann: {
      MicrofacetParams p;
      p.alpha_x = spec.alpha_x;
      p.alpha_y = spec.alpha_y;
      p.fresnel = fresnel_mode(spec);
      p.f0 = spec.f0;
      p.eta = spec.eta;
      p.normalization = spec.normalization;
      if (spec.model == Model::cook_torrance) {
        p.distribution = spec.distribution.value_or(Distribution::beckmann);
        p.masking = spec.masking.value_or(Masking::v_groove);
      } else {
        p.distribution =
            spec.distribution.value_or(spec.model == Model::ggx ? Distribution::ggx : Distribution::beckmann);
        p.masking = spec.masking.value_or(Masking::separable);
      }
      return std::make_unique<MicrofacetBrdf>(p);
    }
    case Model::schlick:
      return std::make_unique<SchlickSingle>(spec.layer);
    case Model::schlick_double:
      return std::make_unique<SchlickDouble>(spec.layer, spec.bottom_layer);
  }
  throw std::invalid_argument("model: unknown model");
}

const char* roughness_name(Model m) {
  if (is_microfacet(m)) return "alpha";
  if (m == Model::schlick || m == Model::schlick_double) return "r";
  if (m == Model::oren_nayar || m == Model::oren_nayar_simple) return "sigma";
  return "none";
}

ModelSpec with_roughness(ModelSpec spec, double roughness) {
  if (is_microfacet(spec.model)) {
    spec.alpha_x = spec.alpha_y = roughness;
  } else if (spec.model == Model::schlick || spec.model == Model::schlick_double) {
    spec.layer.r = roughness;
  } else if (spec.model == Model::oren_nayar || spec.model == Model::oren_nayar_simple) {
    spec.sigma = roughness;
  }
  return spec;
}

}  // namespace kiln::brdf
