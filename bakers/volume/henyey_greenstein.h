// The Henyey–Greenstein phase function (Henyey & Greenstein 1941), with exact sampling and its pdf.
//
// Directions point away from the scattering point, as the BRDFs' do (bxdf.h): wo towards where the light goes (the
// previous path vertex), wi towards where it comes from. μ = cos θ between the direction of travel −wo and wi, so
// g > 0 (forward scattering) sends wi close to −wo:
//   p(μ) = (1 − g²) / (4π (1 + g² − 2gμ)^{3/2}),   ∫ p dω = 1,   mean μ = g.
// p is a probability density in solid angle, so pdf(wo, wi) = p(wo, wi): sampling is exact.
#pragma once

#include "bakers/math/sampling.h"
#include "bakers/math/vec3.h"

namespace kiln::volume {

class HenyeyGreenstein {
 public:
  // |g| → 1 makes p a Dirac delta, which has no density to weigh against light sampling; |g| is narrowed to
  // kMaxAsymmetry. The lobe's width is about 1 − |g| radians: at 1e-4 it is narrower than the sun's disc (4.7e-3
  // rad), so no bake can show a sharper one, and the peak density (1 + |g|)/(4π(1 − |g|)²) ≈ 1.6e7 and the sampling
  // map's denominator 1 + g·a ≥ 1e-4 stay far from overflow and division by zero.
  static constexpr double kMaxAsymmetry = 1.0 - 1e-4;

  // g in [−1, 1]; NaN reads as 0 (isotropic) so that a bad value cannot poison a bake (validation rejects it first).
  explicit HenyeyGreenstein(double g);
  double g() const { return g_; }

  // p as a function of μ = cos∠(−wo, wi).
  double p(double mu) const;
  double p(const Vec3& wo, const Vec3& wi) const { return p(-dot(wo, wi)); }
  double pdf(const Vec3& wo, const Vec3& wi) const { return p(wo, wi); }

  struct Sample {
    Vec3 wi;
    double p = 0;    // the phase function's value for (wo, wi)
    double pdf = 0;  // equal to p
  };
  // wo unit; u uniform on [0, 1)².
  Sample sample(const Vec3& wo, Point2 u) const;
  // The μ the sampling map gives for u ∈ [0, 1): the inverse of the cumulative distribution of μ.
  double sample_mu(double u) const;

 private:
  double g_;
};

}  // namespace kiln::volume
