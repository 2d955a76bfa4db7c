#include "bakers/envmap/lobe.h"

#include <cmath>
#include <vector>

#include "bakers/math/constants.h"
#include "bakers/math/quadrature.h"

namespace kiln::envmap {

namespace {
constexpr EnvLobe kLobes[] = {EnvLobe::ggx, EnvLobe::beckmann, EnvLobe::cook_torrance, EnvLobe::schlick};
}

const char* to_string(EnvLobe lobe) {
  switch (lobe) {
    case EnvLobe::ggx:
      return "ggx";
    case EnvLobe::beckmann:
      return "beckmann";
    case EnvLobe::cook_torrance:
      return "cook_torrance";
    case EnvLobe::schlick:
      return "schlick";
  }
  return "unknown";
}

std::optional<EnvLobe> env_lobe_from_string(const std::string& name) {
  for (EnvLobe l : kLobes) {
    if (name == to_string(l)) return l;
  }
  return std::nullopt;
}

std::string env_lobe_names() {
  std::string s;
  for (EnvLobe l : kLobes) s += (s.empty() ? "" : "|") + std::string(to_string(l));
  return s;
}

brdf::Distribution lobe_distribution(EnvLobe lobe) {
  switch (lobe) {
    case EnvLobe::ggx:
      return brdf::Distribution::ggx;
    case EnvLobe::beckmann:
    case EnvLobe::cook_torrance:
      return brdf::Distribution::beckmann;
    case EnvLobe::schlick:
      return brdf::Distribution::schlick_beckmann;
  }
  return brdf::Distribution::ggx;
}

brdf::Masking dfg_masking(EnvLobe lobe, std::optional<brdf::Masking> asked) {
  if (lobe == EnvLobe::cook_torrance) return brdf::Masking::v_groove;
  return asked.value_or(brdf::Masking::height_correlated);
}

std::optional<std::string> dfg_masking_problem(EnvLobe lobe, brdf::Masking asked) {
  if (lobe == EnvLobe::cook_torrance) {
    if (asked == brdf::Masking::v_groove) return std::nullopt;
    return "cook_torrance's DFG table uses its own V-groove masking; " + brdf::to_string(asked) +
           " applies to the ggx, beckmann and schlick lobes (leave it unset for cook_torrance)";
  }
  if (asked == brdf::Masking::separable || asked == brdf::Masking::height_correlated) return std::nullopt;
  return "must be separable or height-correlated for the " + std::string(to_string(lobe)) + " lobe, got " +
         brdf::to_string(asked);
}

brdf::ModelSpec lobe_model(EnvLobe lobe, brdf::Masking masking) {
  brdf::ModelSpec m;
  switch (lobe) {
    case EnvLobe::ggx:
      m.model = brdf::Model::ggx;
      break;
    case EnvLobe::beckmann:
      m.model = brdf::Model::beckmann;
      break;
    case EnvLobe::cook_torrance:
      m.model = brdf::Model::cook_torrance;
      break;
    case EnvLobe::schlick:
      m.model = brdf::Model::beckmann;  // Walter et al.'s microfacet model with Smith G from Beckmann's Λ ...
      m.distribution = brdf::Distribution::schlick_beckmann;  // ... and Schlick's rational D
      break;
  }
  m.masking = masking;
  return m;
}

brdf::ModelSpec lobe_model(EnvLobe lobe) { return lobe_model(lobe, dfg_masking(lobe)); }

std::string lobe_description(EnvLobe lobe) {
  const char* d = lobe == EnvLobe::ggx       ? "GGX D"
                  : lobe == EnvLobe::schlick ? "Schlick's rational Beckmann D"
                                             : "Beckmann D";
  return std::string(to_string(lobe)) + ": " + d +
         ", alpha = rho^2, rho_k = k/(levels-1); D(h)(n.l) with n = v = r, "
         "normalised by its integral over the sphere";
}

double lobe_normalization(brdf::Distribution distribution, double alpha) {
  const brdf::MicrofacetDistribution dist(distribution, alpha, alpha);
  const Vec3 n{0, 0, 1};
  // The samplers map ξ to θ_h monotonically, GGX's and Beckmann's increasing, Schlick's decreasing (its CDF is taken
  // from the lower end of the support): ξ is flipped for the latter, so that θ_h grows with ξ here.
  const bool flip = dist.sample_wh(n, {0.0, 0.0}).z < dist.sample_wh(n, {0.5, 0.0}).z;
  auto cos_theta = [&](double xi) { return dist.sample_wh(n, {flip ? 1.0 - xi : xi, 0.0}).z; };
  // ξ* where θ_h = π/4 (n·l = 0): cos θ_h decreases with ξ; bisection to double precision.
  const double c45 = std::sqrt(0.5);
  double lo = 0.0, hi = 1.0;
  if (cos_theta(kOneMinusEpsilon) >= c45) {
    lo = hi = 1.0;  // the whole support lies within θ_h < π/4 (Schlick's compact D for m < 1 − 1/√2)
  } else {
    for (int i = 0; i < 200 && hi - lo > 1e-16; ++i) {
      const double mid = 0.5 * (lo + hi);
      (cos_theta(mid) >= c45 ? lo : hi) = mid;
    }
  }
  const double xi_star = 0.5 * (lo + hi);
  // In u = −ln(1 − ξ) the narrow lobes' steep end near ξ = 1 is spread out (GGX: u = ln(1 + tan²θ_h/α²), Beckmann:
  // u = tan²θ_h/α²); the integrand g(ξ(u)) e^(−u) is smooth, integrated on geometrically growing panels.
  const double u_star = xi_star >= 1.0 ? 40.0 : -std::log1p(-xi_star);  // e^(−40): nothing left beyond
  std::vector<double> edges{0.0};
  for (double e = 0.25; e < u_star; e *= 2.0) edges.push_back(e);
  edges.push_back(u_star);
  double w = 0.0;
  for (size_t p = 0; p + 1 < edges.size(); ++p) {
    const QuadratureRule rule = gauss_legendre(16, edges[p], edges[p + 1]);
    for (size_t i = 0; i < rule.nodes.size(); ++i) {
      const double u = rule.nodes[i];
      const double c = cos_theta(std::fmin(-std::expm1(-u), kOneMinusEpsilon));
      w += rule.weights[i] * std::exp(-u) * std::fmax(0.0, 2.0 * c * c - 1.0);
    }
  }
  return 4.0 * w;
}

SplitSumLobe::SplitSumLobe(brdf::Distribution distribution, double alpha)
    : dist_(distribution, alpha, alpha), ggx_(distribution == brdf::Distribution::ggx), alpha2_(alpha * alpha) {}

double SplitSumLobe::weight_from_h(const Vec3& n, const Vec3& l, double nl) const {
  const Vec3 h = normalize(n + l);
  // D depends only on n·h for these isotropic lobes: evaluate it in a frame where n is +z.
  const double nh = std::fmin(1.0, dot(n, h));
  const Vec3 h_local{std::sqrt(std::fmax(0.0, 1.0 - nh * nh)), 0.0, nh};
  return dist_.D(h_local) * nl;
}

}  // namespace kiln::envmap
