// Schlick 1994, "An Inexpensive BRDF Model for Physically-based Rendering", in an energy-conserving form.
// Single layer: S(u) [f_ss + f_ms] (schlick_layer_model.h): Schlick's microfacet term, plus the energy its masking
// removes given back diffusely, so that C = 1 loses and creates nothing and r = 1, p = 1 is Lambertian. Double layer:
// f_top + T(wo) T(wi) f_bottom with T = 1 − E_top per channel (the interreflection between the layers is neglected).
// Both are reciprocal with albedo ≤ 1. Where and why this departs from the survey's printed eq 22–25 (the diffuse
// f_ms, the masking constant k, the normalised A, r = 0 and p = 0): docs/BRDF.md, section "Schlick's model".
// The pieces: schlick_azimuth.h (A_n: sampling, quadrature), schlick_tables.h (E and E5 over wo),
// schlick_layer_model.h (one layer); this file holds the public classes.
#include "bakers/brdf/schlick.h"

#include <memory>
#include <string>

#include "bakers/bake/invalid_input.h"
#include "bakers/bake/number_format.h"
#include "bakers/brdf/schlick_layer_model.h"

namespace kiln::brdf {
namespace {

using detail::SchlickLayerModel;

// The constructors' own guard (brdf::validate reports the same problems first, for a whole ModelSpec).
void check_layer(const SchlickLayer& l, const char* prefix) {
  auto bad = [&](const char* field, double v) {
    return bake::InvalidInput(std::string(prefix) + field, "must be in [0, 1], got " + bake::format_number(v));
  };
  for (int i = 0; i < 3; ++i) {
    if (!(l.c[i] >= 0.0 && l.c[i] <= 1.0)) throw bad("c", l.c[i]);
  }
  if (!(l.r >= 0.0 && l.r <= 1.0)) throw bad("r", l.r);
  if (!(l.p >= 0.0 && l.p <= 1.0)) throw bad("p", l.p);
}

std::string describe_layer(const SchlickLayer& l) {
  return "c=" + bake::format_rgb(l.c) + ", r=" + bake::format_number(l.r) + ", p=" + bake::format_number(l.p);
}

}  // namespace

// ---------------------------------------------------------------------------------------------------------------
struct SchlickSingle::Impl {
  explicit Impl(const SchlickLayer& l) : model(l) {}
  SchlickLayerModel model;
};

SchlickSingle::SchlickSingle(const SchlickLayer& layer) {
  check_layer(layer, "");
  impl_ = std::make_unique<Impl>(layer);
}
SchlickSingle::~SchlickSingle() = default;

Rgb SchlickSingle::eval(const Vec3& wo, const Vec3& wi) const { return impl_->model.eval(wo, wi); }

std::optional<BsdfSample> SchlickSingle::sample(const Vec3& wo, Point2 u, double) const {
  if (!above_horizon(wo)) return std::nullopt;
  const Vec3 wi = impl_->model.sample_direction(wo, u);
  return make_sample(wi, eval(wo, wi), pdf(wo, wi));  // fails below the horizon
}

double SchlickSingle::pdf(const Vec3& wo, const Vec3& wi) const { return impl_->model.pdf(wo, wi); }

std::string SchlickSingle::describe() const { return "schlick(" + describe_layer(impl_->model.layer()) + ")"; }

// ---------------------------------------------------------------------------------------------------------------
// f = f_top + T(wo) T(wi) f_bottom: light reaches the bottom through the top and leaves through it again; what the
// top's underside reflects back down is neglected, so some energy is lost (measured in schlick_test).
bool SchlickSingle::isotropic() const { return impl_->model.layer().p == 1.0; }

struct SchlickDouble::Impl {
  Impl(const SchlickLayer& t, const SchlickLayer& b) : top(t), bottom(b) {}
  SchlickLayerModel top, bottom;

  // T = 1 − E_top = 1 − (C + (1 − C) E5) = (1 − C)(1 − E5), per channel.
  Rgb transmission(const Vec3& w) const { return (Rgb(1.0) - top.layer().c) * (1.0 - top.e5(w)); }
  Rgb full_albedo(const SchlickLayerModel& m, const Vec3& w) const {
    return m.layer().c + (Rgb(1.0) - m.layer().c) * m.e5(w);
  }
  // Probability of sampling the top layer: its expected share of the reflected energy at wo.
  double top_probability(const Vec3& wo) const {
    const double wt = full_albedo(top, wo).average();
    const double wb = (transmission(wo) * full_albedo(bottom, wo)).average();
    // Both zero only for a black top over a black bottom, where nothing is reflected: any split will do.
    return wt + wb > 0 ? wt / (wt + wb) : 0.5;
  }
};

SchlickDouble::SchlickDouble(const SchlickLayer& top, const SchlickLayer& bottom) {
  check_layer(top, "top.");
  check_layer(bottom, "bottom.");
  impl_ = std::make_unique<Impl>(top, bottom);
}
SchlickDouble::~SchlickDouble() = default;

Rgb SchlickDouble::eval(const Vec3& wo, const Vec3& wi) const {
  if (!valid_reflection_pair(wo, wi)) return Rgb{};
  return impl_->top.eval(wo, wi) + impl_->transmission(wo) * impl_->transmission(wi) * impl_->bottom.eval(wo, wi);
}

std::optional<BsdfSample> SchlickDouble::sample(const Vec3& wo, Point2 u, double) const {
  if (!above_horizon(wo)) return std::nullopt;
  const double pt = impl_->top_probability(wo);
  // The layer is chosen by u.x, rescaled to [0, 1) for the chosen layer (which splits it again between its lobes):
  // stratification of u carries over to the choice (schlick_layer_model.h).
  Vec3 wi;
  if (u.x < pt) {
    wi = impl_->top.sample_direction(wo, {std::fmin(u.x / pt, kOneMinusEpsilon), u.y});
  } else {
    wi = impl_->bottom.sample_direction(wo, {std::fmin((u.x - pt) / (1.0 - pt), kOneMinusEpsilon), u.y});
  }
  return make_sample(wi, eval(wo, wi), pdf(wo, wi));  // fails below the horizon
}

double SchlickDouble::pdf(const Vec3& wo, const Vec3& wi) const {
  if (!valid_reflection_pair(wo, wi)) return 0.0;
  const double pt = impl_->top_probability(wo);
  return pt * impl_->top.pdf(wo, wi) + (1.0 - pt) * impl_->bottom.pdf(wo, wi);
}

std::string SchlickDouble::describe() const {
  return "schlick-double(top: " + describe_layer(impl_->top.layer()) +
         "; bottom: " + describe_layer(impl_->bottom.layer()) + ")";
}

bool SchlickDouble::isotropic() const { return impl_->top.layer().p == 1.0 && impl_->bottom.layer().p == 1.0; }

}  // namespace kiln::brdf
