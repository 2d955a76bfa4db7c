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

  // Samples a microfacet normal seen from wo (wo.z > 0): GGX samples the visible normals exactly (Heitz 2018);
  // Beckmann and Schlick's rational D sample their own D(wh) cos θ_h (Beckmann slopes are Gaussian; the rational
  // D has a closed-form inverse CDF).
  Vec3 sample_wh(const Vec3& wo, Point2 u) const;
  // Density of sample_wh per solid angle of wh.
  double pdf_wh(const Vec3& wo, const Vec3& wh) const;

 private:
  // Beckmann's normalised D.
  double D_beckmann(const Vec3& wh) const;

  Distribution kind_;
  double alpha_x_, alpha_y_;
};

}  // namespace kiln::brdf
