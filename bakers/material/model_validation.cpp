#include "bakers/material/model_validation.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "bakers/material/table_entry.h"
#include "bakers/math/rng.h"
#include "bakers/math/sampling.h"

namespace kiln::material {
namespace {

using brdf::Estimate;

// The exact form's albedo at μ, channel by channel from its per-channel models (one model for all three when grey).
void exact_albedo(const std::vector<std::unique_ptr<brdf::Bxdf>>& exact, double mu, const brdf::AlbedoOptions& o,
                  Rgb* value, Rgb* std_error) {
  Estimate per_channel[3];
  for (int c = 0; c < 3; ++c) {
    if (c > 0 && exact.size() == 1) {
      per_channel[c] = per_channel[0];
    } else {
      per_channel[c] = brdf::directional_albedo(*exact[exact.size() == 1 ? 0 : c], mu, o);
    }
  }
  *value = {per_channel[0].value.r, per_channel[1].value.g, per_channel[2].value.b};
  *std_error = {per_channel[0].std_error.r, per_channel[1].std_error.g, per_channel[2].std_error.b};
}

}  // namespace

EnergyCheck check_energy(const brdf::AlbedoTable& albedo, const brdf::AlbedoTable& white_furnace) {
  EnergyCheck en;
  for (size_t i = 0; i < albedo.e.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      const double val = albedo.e[i].value[c];
      if (val > en.max_albedo || (i == 0 && c == 0)) {
        en.max_albedo = val;
        en.max_albedo_mu = albedo.mu[i];
        en.max_albedo_channel = c;
        en.max_albedo_error = albedo.e[i].std_error[c];
      }
    }
    const double w = white_furnace.e[i].value.max();
    if (w > en.white_max_albedo || i == 0) {
      en.white_max_albedo = w;
      en.white_max_albedo_mu = white_furnace.mu[i];
      en.white_max_albedo_error = white_furnace.e[i].std_error.max();
    }
  }
  en.conserves_energy = en.max_albedo <= 1.0 + 3.0 * en.max_albedo_error + 1e-9 &&
                        en.white_max_albedo <= 1.0 + 3.0 * en.white_max_albedo_error + 1e-9;
  return en;
}

ReciprocityCheck check_reciprocity(const brdf::Bxdf& bxdf, uint64_t seed) {
  ReciprocityCheck rc;
  rc.pairs = kReciprocityPairs;
  rc.model_claims_reciprocal = bxdf.reciprocal();
  Pcg32 rng(splitmix64(seed) ^ 0x7265636970ULL, 5);
  for (int p = 0; p < kReciprocityPairs; ++p) {
    const Vec3 wo = sample_uniform_hemisphere({rng.uniform(), rng.uniform()});
    const Vec3 wi = sample_uniform_hemisphere({rng.uniform(), rng.uniform()});
    const Rgb a = bxdf.eval(wo, wi), b = bxdf.eval(wi, wo);
    for (int c = 0; c < 3; ++c) {
      const double m = std::max(a[c], b[c]);
      if (!(m > 0)) continue;
      const double rel = std::fabs(a[c] - b[c]) / m;
      if (rel > rc.max_relative_difference) {
        rc.max_relative_difference = rel;
        rc.worst_wo = wo;
        rc.worst_wi = wi;
      }
    }
  }
  return rc;
}

ApproximationError measure_approximation(const brdf::Bxdf& bxdf, const Comparison& cmp, int n_mu, uint64_t seed,
                                         ProgressTracker& progress, uint64_t* samples) {
  std::vector<std::unique_ptr<brdf::Bxdf>> exact;
  for (const auto& s : cmp.exact) exact.push_back(brdf::make_bxdf(s));
  std::vector<Estimate> approx_e(n_mu);
  std::vector<Rgb> exact_v(n_mu), exact_se(n_mu);
  tbb::parallel_for(0, n_mu, [&](int i) {
    progress.check_cancel();
    brdf::AlbedoOptions o;
    o.samples = kApproximationSamples;
    o.replicates = kReplicates;
    // The same seed on both sides: the models share their sampling, so the difference is nearly noise-free.
    o.seed = block_seed(seed, 1u << 20, static_cast<uint64_t>(i));
    approx_e[i] = brdf::directional_albedo(bxdf, mu_at(i, n_mu), o);
    exact_albedo(exact, mu_at(i, n_mu), o, &exact_v[i], &exact_se[i]);
    const uint64_t n = static_cast<uint64_t>(approx_e[i].samples) * (1 + cmp.exact.size());
    progress.step("validation", static_cast<double>(n), n);
  });
  ApproximationError ae;
  ae.name = cmp.name;
  double sum = 0;
  for (int i = 0; i < n_mu; ++i) {
    for (int c = 0; c < 3; ++c) {
      const double d = std::fabs(approx_e[i].value[c] - exact_v[i][c]);
      sum += d;
      if (d > ae.max_abs_difference || (i == 0 && c == 0)) {
        ae.max_abs_difference = d;
        ae.at_mu = mu_at(i, n_mu);
        ae.std_error = std::hypot(approx_e[i].std_error[c], exact_se[i][c]);
      }
    }
    *samples += static_cast<uint64_t>(approx_e[i].samples) * (1 + cmp.exact.size());
  }
  ae.mean_abs_difference = sum / (3.0 * n_mu);
  return ae;
}

}  // namespace kiln::material
