#include "bakers/brdf/albedo.h"

#include <cmath>
#include <functional>
#include <stdexcept>

#include "bakers/math/constants.h"
#include "bakers/math/rng.h"

namespace kiln::brdf {
namespace {

Vec3 direction_from(double mu, double phi) {
  const double s = std::sqrt(std::fmax(0.0, 1.0 - mu * mu));
  return {s * std::cos(phi), s * std::sin(phi), mu};
}

Rgb weight_or_zero(const std::optional<BsdfSample>& s) { return s ? s->weight : Rgb{}; }

int strata_per_side(const AlbedoOptions& options, int replicates) {
  const int per_replicate = std::max(1, (options.samples + replicates - 1) / replicates);
  return std::max(1, static_cast<int>(std::ceil(std::sqrt(static_cast<double>(per_replicate)))));
}

}  // namespace

int64_t stratified_sample_count(const AlbedoOptions& options) {
  const int replicates = std::max(2, options.replicates);
  const int n = strata_per_side(options, replicates);
  return static_cast<int64_t>(replicates) * n * n;
}

Estimate stratified_estimate(const AlbedoOptions& options, uint64_t stream, const SampleContribution& contribution) {
  const int replicates = std::max(2, options.replicates);
  const int n = strata_per_side(options, replicates);
  Rgb sum, sum_sq;
  for (int rep = 0; rep < replicates; ++rep) {
    Pcg32 rng(options.seed + 0x9e3779b97f4a7c15ULL * static_cast<uint64_t>(rep + 1), stream);
    Rgb acc;
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) {
        const Point2 u{(i + rng.uniform()) / n, (j + rng.uniform()) / n};
        const double uc = rng.uniform();
        acc += contribution(u, uc, rng);
      }
    }
    const Rgb mean = acc / static_cast<double>(n * n);
    sum += mean;
    sum_sq += mean * mean;
  }
  Estimate e;
  e.value = sum / replicates;
  const Rgb var = (sum_sq / replicates - e.value * e.value) * (static_cast<double>(replicates) / (replicates - 1));
  const auto se = [&](double v) { return std::sqrt(std::fmax(0.0, v) / replicates); };
  e.std_error = Rgb{se(var.r), se(var.g), se(var.b)};
  e.samples = static_cast<int64_t>(replicates) * n * n;
  return e;
}

Estimate directional_albedo(const Bxdf& bxdf, const Vec3& wo, const AlbedoOptions& options) {
  if (!above_horizon(wo)) return Estimate{};  // no light leaves towards or below the horizon: E = 0
  return stratified_estimate(options, 1,
                             [&](Point2 u, double uc, Pcg32&) { return weight_or_zero(bxdf.sample(wo, u, uc)); });
}

Estimate directional_albedo(const Bxdf& bxdf, double mu, const AlbedoOptions& options) {
  if (!(mu > 0)) return Estimate{};
  mu = std::fmin(mu, 1.0);
  // An anisotropic model is averaged over the azimuth of wo, drawn per sample. An isotropic one has the same E at
  // every azimuth, so wo stays at φ = 0: a per-sample azimuth would add no bias but would undo the stratification
  // of samplers that work in the fixed frame (cosine-weighted ones draw φi = 2π u.y, so φi − φo would be random),
  // which made Oren–Nayar's and Schlick's standard errors 10–50× larger than their samplers allow.
  if (bxdf.isotropic()) return directional_albedo(bxdf, direction_from(mu, 0.0), options);
  return stratified_estimate(options, 2, [&](Point2 u, double uc, Pcg32& rng) {
    const Vec3 wo = direction_from(mu, 2.0 * kPi * rng.uniform());
    return weight_or_zero(bxdf.sample(wo, u, uc));
  });
}

AlbedoTable albedo_table(const Bxdf& bxdf, int n_mu, const AlbedoOptions& options) {
  if (n_mu < 1) throw std::invalid_argument("albedo_table: n_mu must be at least 1, got " + std::to_string(n_mu));
  AlbedoTable table;
  for (int i = 0; i < n_mu; ++i) {
    const double mu = (i + 0.5) / n_mu;
    table.mu.push_back(mu);
    table.e.push_back(directional_albedo(bxdf, mu, options));
  }
  // E_avg = 2 ∫ E(μ) μ dμ is the mean of E(μ) for μ drawn with density 2μ: μ = sqrt(ξ). Estimated directly
  // (not from the table) so that its error is the estimator's, not the table's midpoint-rule error.
  AlbedoOptions avg = options;
  avg.samples = options.samples * 4;
  table.average = stratified_estimate(avg, 3, [&](Point2 u, double uc, Pcg32& rng) {
    const double mu = std::sqrt(1.0 - rng.uniform());  // 1 − ξ ∈ (0, 1]: μ > 0
    const Vec3 wo = direction_from(mu, 2.0 * kPi * rng.uniform());
    return weight_or_zero(bxdf.sample(wo, u, uc));
  });
  return table;
}

SplitSumEntry split_sum_entry(const Bxdf& white_lobe, double mu, const AlbedoOptions& options) {
  // One estimator for all three integrals: red carries the scale part, green the bias part, blue their sum.
  const Estimate e = stratified_estimate(options, 4, [&](Point2 u, double uc, Pcg32& rng) {
    // The azimuth of wo is drawn too: it averages an anisotropic lobe and costs an isotropic one nothing.
    const Vec3 wo = direction_from(mu, 2.0 * kPi * rng.uniform());
    const auto s = white_lobe.sample(wo, u, uc);
    if (!s) return Rgb{};
    const double c = std::pow(1.0 - std::fmax(0.0, dot(wo, normalize(wo + s->wi))), 5.0);
    const double w = s->weight.average();
    return Rgb{w * (1.0 - c), w * c, w};
  });
  return SplitSumEntry{e.value.r, e.value.g, e.value.b, e.std_error.r, e.std_error.g, e.std_error.b, e.samples};
}

ModelSpec without_fresnel(ModelSpec spec) {
  spec.fresnel = FresnelMode::none;
  spec.albedo = Rgb{1.0};
  spec.f0 = Rgb{1.0};
  spec.layer.c = Rgb{1.0};
  spec.bottom_layer.c = Rgb{1.0};
  return spec;
}

double max_roughness(Model m) {
  (void)m;
  return 1.0;  // α ∈ (0, 1], r ∈ [0, 1], σ ∈ [0, 1] rad: every model's axis ends at 1
}

SplitSumTable split_sum_table(const ModelSpec& spec, int n_mu, int n_roughness, const AlbedoOptions& options) {
  if (n_mu < 1 || n_roughness < 1) {
    throw std::invalid_argument("split_sum_table: n_mu and n_roughness must be at least 1, got " +
                                std::to_string(n_mu) + " and " + std::to_string(n_roughness));
  }
  SplitSumTable t;
  t.n_mu = n_mu;
  t.n_roughness = n_roughness;
  for (int i = 0; i < n_mu; ++i) t.mu.push_back((i + 0.5) / n_mu);
  for (int j = 0; j < n_roughness; ++j) t.roughness.push_back((j + 0.5) / n_roughness * max_roughness(spec.model));
  const ModelSpec white = without_fresnel(spec);
  for (int j = 0; j < n_roughness; ++j) {
    const std::unique_ptr<Bxdf> bxdf = make_bxdf(with_roughness(white, t.roughness[j]));
    for (int i = 0; i < n_mu; ++i) {
      const SplitSumEntry e = split_sum_entry(*bxdf, t.mu[i], options);
      t.scale.push_back(e.scale);
      t.bias.push_back(e.bias);
      t.scale_error.push_back(e.scale_error);
      t.bias_error.push_back(e.bias_error);
    }
  }
  return t;
}

}  // namespace kiln::brdf
