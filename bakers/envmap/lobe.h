// The specular lobe of an environment bake: which distribution of normals D the prefiltered chain convolves with
// and the DFG table integrates, the one roughness mapping, and the lobe's normalisation.
//
// ## Lobes (EnvLobe) and their D (bakers/brdf/microfacet_distribution)
//   ggx            GGX / Trowbridge–Reitz, α = ρ²
//   beckmann       Beckmann, α (= m) = ρ²
//   cook_torrance  Cook–Torrance's own D, which is Beckmann's (bakers/brdf: Model::cook_torrance defaults to
//                  Distribution::beckmann), α = ρ²; the prefiltered chain equals beckmann's, the DFG table differs
//                  (V-groove masking instead of Smith's).
//   schlick        Schlick's rational approximation of Beckmann (survey eq 20, Distribution::schlick_beckmann) with
//                  m = ρ². Note: Schlick's own BRDF's Z(t) = r/(1 + r t² − t²)² is exactly GGX with α² = r, so
//                  with dfg.h's r = ρ⁴ it would give the GGX chain bit for bit; the rational Beckmann is the D that
//                  is Schlick's and not already offered. Its DFG table uses the microfacet model with that D and
//                  Smith masking from Beckmann's Λ (the pairing bakers/brdf documents).
// ρ is the perceptual roughness of a level: ρ_k = k/(L − 1) for level k of L (prefilter.h).
//
// ## Normalisation
// The split-sum lobe with n = v = r is D(h)(n·l) with h = (n + l)/|n + l|. Its integral over the sphere,
//     W(α) = ∫_{n·l>0} D(h) (n·l) dω_l = 4 ∫_{θ_h<π/4} D(h) (n·h) (2(n·h)² − 1) dω_h,
// does not depend on n (the lobes are isotropic). Written with the sampler's inverse CDF of D(h)(n·h) in ξ
// (θ_h grows with ξ): W = 4 ∫_0^ξ* (2 cos²θ_h(ξ) − 1) dξ, ξ* where θ_h = π/4, integrated by Gauss–Legendre.
#pragma once

#include <optional>
#include <string>

#include "bakers/brdf/microfacet_distribution.h"
#include "bakers/brdf/model_spec.h"
#include "bakers/math/constants.h"
#include "bakers/math/vec3.h"

namespace kiln::envmap {

enum class EnvLobe { ggx, beckmann, cook_torrance, schlick };
const char* to_string(EnvLobe lobe);
std::optional<EnvLobe> env_lobe_from_string(const std::string& name);
// "ggx|beckmann|cook_torrance|schlick", for error messages.
std::string env_lobe_names();

// The distribution of normals of the lobe (see above).
brdf::Distribution lobe_distribution(EnvLobe lobe);
// The masking of the lobe's DFG table (the prefiltered chain depends on D only). The Smith lobes (ggx, beckmann,
// schlick) take separable or height-correlated Smith masking, height-correlated by default: it is the exact Smith
// form for uncorrelated heights (Heitz 2014, eq 99), what Filament and Unreal ship, and what a material bake with
// masking height-correlated tabulates; the separable form masks twice where the heights correlate and is up to 0.15
// darker at grazing angles and high roughness. cook_torrance's masking is its V-groove G, not a choice.
// `asked` unset gives the default.
brdf::Masking dfg_masking(EnvLobe lobe, std::optional<brdf::Masking> asked = std::nullopt);
// What is wrong with asking for `asked` with this lobe (the problem of an InvalidInput on dfg_masking), or nullopt.
std::optional<std::string> dfg_masking_problem(EnvLobe lobe, brdf::Masking asked);
// The BRDF model whose white (Fresnel-free) split-sum table dfg.exr holds, with the DFG masking `masking`
// (dfg_masking()); roughness set by lobe_at_roughness.
brdf::ModelSpec lobe_model(EnvLobe lobe, brdf::Masking masking);
brdf::ModelSpec lobe_model(EnvLobe lobe);  // with dfg_masking(lobe)
// α (or m) of perceptual roughness ρ: ρ² for every lobe.
inline double lobe_alpha(double rho) { return rho * rho; }
// One line for metadata and reports: the D, the mapping and the weighting.
std::string lobe_description(EnvLobe lobe);

// W(α) above, for alpha > 0 (Gauss–Legendre in u = −ln(1 − ξ); tests/envmap/lobe_test.cpp checks it against
// quadrature over the sphere).
double lobe_normalization(brdf::Distribution distribution, double alpha);

// D(h)(n·l) of the lobe around unit n for unit l (0 for n·l ≤ 0, which also excludes l = −n, where h is undefined).
// Inline: the brute-force references sum it over every source texel, so it is most of their cost.
class SplitSumLobe {
 public:
  SplitSumLobe(brdf::Distribution distribution, double alpha);
  double weight(const Vec3& n, const Vec3& l) const {
    const double nl = dot(n, l);
    if (nl <= 0.0) return 0.0;  // below the horizon of n (and l = −n, where h is undefined)
    if (!ggx_) return weight_from_h(n, l, nl);
    // For unit n and l, (n·h)² = (1 + n·l)/2, and GGX's D = α² / (π (1 + (n·h)² (α² − 1))²) (the form of
    // MicrofacetDistribution::D, multiplied through by α²): no normalisation and no square root.
    const double e = 1.0 + 0.5 * (1.0 + nl) * (alpha2_ - 1.0);
    return alpha2_ * kInvPi / (e * e) * nl;
  }
  const brdf::MicrofacetDistribution& distribution() const { return dist_; }

 private:
  // The other lobes: D(h) from the half vector.
  double weight_from_h(const Vec3& n, const Vec3& l, double nl) const;

  brdf::MicrofacetDistribution dist_;
  bool ggx_;
  double alpha2_;
};

}  // namespace kiln::envmap
