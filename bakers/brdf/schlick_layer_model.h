// One layer of Schlick's model (C, r, p) in its energy-conserving form (schlick_*.cpp only). In the local frame with
// the normal along +z, with t = n·h, u = wo·h, v = n·wi, v' = n·wo and w = cos of the azimuth of h from the tangent x:
//
//   f(wo, wi) = S(u) [f_ss + f_ms]
//   S(u)   = C + (1 − C)(1 − u)^5                              (survey eq 18)
//   f_ss   = G(wi) G(wo) Z(t) A_n(w) / (4π v v')               (Schlick's microfacet term: single scattering)
//   f_ms   = (1 − E(wo)) (1 − E(wi)) / (π (1 − Ē))             (the energy masking removed, given back diffusely)
//   Z(t)   = r / (1 + r t² − t²)²                              (eq 24; Z/π is GGX with α² = r: ∫ Z t dω_h = π)
//   A_n(w) = A(w) AGM(1, p) / sqrt(p),  A(w) = sqrt(p / (p² − p² w² + w²))   (eq 24, normalised)
//   G(w)   = v / (k − k v + v),  k = α_w (1 + α_w) / 2,  α_w² = 2 r (c_x cos²φ_w + (1 − c_x) sin²φ_w)
//   E(wo)  = ∫ f_ss cos θi dωi, tabulated over μ = cos θo (and sin φo when p < 1); Ē = (1/π) ∫ E cos θ dω.
//   c_x    = the mean of cos²φ_h under A_n (1/2 for p = 1, so that α_w = α = sqrt(r)).
//
// Why these forms and not the survey's printed ones: docs/BRDF.md, "Schlick's model".
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <vector>

#include "bakers/brdf/bxdf.h"
#include "bakers/brdf/fresnel.h"
#include "bakers/brdf/model_spec.h"
#include "bakers/brdf/schlick_azimuth.h"
#include "bakers/brdf/schlick_internal.h"
#include "bakers/brdf/schlick_tables.h"
#include "bakers/math/constants.h"

namespace kiln::brdf::detail {

// One layer: everything but S(u) is white; tables are built (or found in the cache) at construction.
class SchlickLayerModel {
 public:
  explicit SchlickLayerModel(const SchlickLayer& layer);

  const SchlickLayer& layer() const { return layer_; }

  // G(w) / v for a direction w with v = n·w and q = sin²φ_w, finite at grazing angles. k grows with the roughness
  // projected on the plane of incidence: α_w² = 2 r (c_x cos²φ_w + (1 − c_x) sin²φ_w), c_x = mean of cos²φ_h.
  double g_over_v(double v, double q) const {
    const double k = masking_k(q);
    return 1.0 / (k + (1.0 - k) * v);
  }
  double g_over_v(const Vec3& w) const { return g_over_v(w.z, sin2_phi(w)); }
  double masking_k(double q) const {
    if (azimuth_.isotropic()) return k_;
    const double a = alpha_ * std::sqrt(2.0 * (cx_ * (1.0 - q) + (1.0 - cx_) * q));
    return 0.5 * a * (1.0 + a);
  }
  // Z(t) with 1 + r t² − t² written as sin²θ_h + r t², exact for h at the normal.
  double Z(const Vec3& h) const {
    const double d = h.x * h.x + h.y * h.y + r_ * h.z * h.z;
    return r_ / (d * d);
  }

  // The white BRDF (S excluded) and u = wo·h, for a valid pair.
  double white(const Vec3& wo, const Vec3& wi, double* u_out) const {
    const Vec3 h = half_vector(wo, wi);
    const double u = std::clamp(dot(wo, h), 0.0, 1.0);
    *u_out = u;
    const double ss = g_over_v(wi) * g_over_v(wo) * Z(h) * azimuth_.factor(h.x, h.y) * kInv4Pi;
    const double ms = tables_->ms_scale * (1.0 - tables_->e.lookup(wo)) * (1.0 - tables_->e.lookup(wi));
    return ss + ms;
  }

  Rgb eval(const Vec3& wo, const Vec3& wi) const {
    if (!valid_reflection_pair(wo, wi)) return Rgb{};
    double u;
    const double f = white(wo, wi, &u);
    return fresnel_schlick(u, layer_.c) * f;
  }

  // Probability of sampling the microfacet lobe at wo.
  double lobe_probability(const Vec3& wo) const { return std::clamp(tables_->e.lookup(wo), 0.0, 1.0); }

  double pdf(const Vec3& wo, const Vec3& wi) const {
    if (!valid_reflection_pair(wo, wi)) return 0.0;
    const double ps = lobe_probability(wo);
    const Vec3 h = half_vector(wo, wi);
    const double u = dot(wo, h);
    // D(h) t / (4 u): the density of h, times the Jacobian of the reflection. u > 0 for two upper directions.
    const double spec = u > 0 ? Z(h) * azimuth_.factor(h.x, h.y) * h.z / (4.0 * kPi * u) : 0.0;
    return ps * spec + (1.0 - ps) * cosine_hemisphere_pdf(wi.z);
  }

  // wi by the model's mixture: with probability E(wo) the microfacet lobe (wi = reflect(wo, h)), otherwise a
  // cosine-weighted direction; below the horizon when the reflection falls there (the sample then fails). The lobe
  // is chosen by u.x itself, which is then rescaled to [0, 1) for the chosen lobe: a separate random number for the
  // choice would not be stratified with u, and the two lobes' different directions made that choice the largest
  // part of an albedo estimate's variance (3e-4 at 2^20 samples, against 1e-5 for one lobe alone).
  Vec3 sample_direction(const Vec3& wo, Point2 u) const {
    const double ps = lobe_probability(wo);
    if (u.x < ps) return reflect(wo, sample_normal({std::fmin(u.x / ps, kOneMinusEpsilon), u.y}));
    return sample_cosine_hemisphere({std::fmin((u.x - ps) / (1.0 - ps), kOneMinusEpsilon), u.y});
  }

  // A normal with density D(h) t: tan²θ_h = r ξ / (1 − ξ) (GGX with α² = r), φ_h exactly from A_n.
  Vec3 sample_normal(Point2 u) const {
    const double xi = u.x;
    const double denom = (1.0 - xi) + r_ * xi;
    const double t = std::sqrt((1.0 - xi) / denom), st = std::sqrt(r_ * xi / denom);
    double c, s;
    azimuth_.sample(u.y, &c, &s);
    return {st * c, st * s, t};
  }

  // Albedo of the whole white layer weighted by Schlick's (1 − u)^5, for the double layer.
  double e5(const Vec3& w) const { return tables_->e5.lookup(w); }

 private:
  struct AlbedoPair {
    double e = 0, e5 = 0;
  };
  // The outgoing direction of one table node, with what every normal's contribution needs of it.
  struct Outgoing {
    double mu = 0, phi_o = 0, so = 0;  // cos θo, φo, sin θo
    Vec3 wo;
    double gv_o = 0;  // G(wo) / v'
  };

  AlbedoPair single_scattering_albedo(double mu, double phi_o) const;
  void add_every_azimuth(const Outgoing& o, double eta_a, AlbedoPair& sum) const;
  void add_partial_azimuths(const Outgoing& o, double eta_a, double eta_b, AlbedoPair& sum) const;
  void add_normal_angle(const Outgoing& o, double eta, double weight, bool partial, AlbedoPair& sum) const;
  LayerTables build_tables() const;
  static void add_diffuse_e5(LayerTables& t);

  SchlickLayer layer_;
  double r_, alpha_, k_;
  Azimuth azimuth_;
  std::vector<std::array<double, 3>> circle_nodes_;  // (cos φ, sin φ, weight) over the whole turn
  double cx_ = 0.5;                                  // mean of cos²φ_h under A_n (1/2 when isotropic)
  std::shared_ptr<const LayerTables> tables_;
};

}  // namespace kiln::brdf::detail
