// Distributions of microfacet normals (GGX, Beckmann, Schlick's rational Beckmann) with their Smith masking,
// in the local frame (normal +z), anisotropic with widths alpha_x along the tangent (x) and alpha_y along y.
//
// D is normalised in the projected-area sense, ∫ D(wh) cos θ_h dω_h = 1 (Walter et al. 2007, eq 4), so the survey's
// eq 13 (Beckmann without 1/π) and eq 20 (Schlick's rational Beckmann, which integrates to π) are divided by π here.
#pragma once

#include "bakers/brdf/model_spec.h"
#include "bakers/math/sampling.h"
#include "bakers/math/vec3.h"

namespace kiln::brdf {

class MicrofacetDistribution {
 public:
  // alpha_x, alpha_y > 0 (validated by the caller). Schlick's rational Beckmann is isotropic: it uses
  // alpha = sqrt(alpha_x alpha_y).
  MicrofacetDistribution(Distribution kind, double alpha_x, double alpha_y);

  Distribution kind() const { return kind_; }
  double alpha_x() const { return alpha_x_; }
  double alpha_y() const { return alpha_y_; }

  // D(wh) with the χ⁺(wh·n) factor: zero for wh at or below the horizon.
  double D(const Vec3& wh) const;
  // Smith's Λ(w) for this distribution (for Schlick's rational D, the exact Beckmann Λ). Λ = 0 at the normal.
  double Lambda(const Vec3& w) const;
  // Smith's monodirectional masking G1(w) = 1 / (1 + Λ(w)), without the χ⁺ factor on w·wh.
  double G1(const Vec3& w) const { return 1.0 / (1.0 + Lambda(w)); }
  // The distribution of visible normals D_w(wh) = G1(w) max(0, w·wh) D(wh) / cos θ_w (Heitz 2014, eq 2).
  double D_visible(const Vec3& w, const Vec3& wh) const;

  // Samples a microfacet normal seen from wo (wo.z > 0) from the visible normals D_visible(wo, wh): GGX by Heitz
  // 2018, Beckmann by Heitz & d'Eon 2014 (beckmann_visible.h). Schlick's rational D has no Smith Λ of its own, so it
  // has no visible normals in Smith's sense: it samples D(wh) cos θ_h (a closed-form inverse CDF), and the models
  // sample its V-cavity visible normals instead (sample_wh_v_cavity). Seen from the normal every variant draws
  // D(wh) cos θ_h.
  Vec3 sample_wh(const Vec3& wo, Point2 u) const;
  // Density of sample_wh per solid angle of wh.
  double pdf_wh(const Vec3& wo, const Vec3& wh) const;

  // Samples D(wh) cos θ_h, the normals weighted by their projected area on the mean surface.
  Vec3 sample_wh_projected(Point2 u) const;
  // The visible normals of the V-cavity microsurface built on this D (Heitz & d'Eon 2014, section 5.1): every
  // facet wh is paired with its mirror image (−wh.x, −wh.y, wh.z) into a V, and G1(wo, wh) = min(1, 2 (n·wh)(n·wo) /
  // (wo·wh)) is the masking of Torrance–Sparrow's and Cook–Torrance's V-groove G. The density
  // D(wh) min(wo·wh, 2 (n·wh)(n·wo)) / (n·wo) integrates to 1 for every D symmetric under wh → mirror image (all
  // three here): it samples the V-groove models exactly and, for Schlick's rational D, bounds the weight where
  // D cos θ_h would not. The map from u is monotone in each coordinate, so stratification carries over.
  Vec3 sample_wh_v_cavity(const Vec3& wo, Point2 u) const;
  double pdf_wh_v_cavity(const Vec3& wo, const Vec3& wh) const;

 private:
  // Beckmann's normalised D.
  double D_beckmann(const Vec3& wh) const;
  // The slope radius of unit roughness drawn from u for the D cos θ_h of GGX and Beckmann.
  double slope_radius(double u) const;
  // cos θ_h drawn from u for the D cos θ_h of Schlick's rational D.
  double rational_cos_theta(double u) const;

  Distribution kind_;
  double alpha_x_, alpha_y_;
};

}  // namespace kiln::brdf
