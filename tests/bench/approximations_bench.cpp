// What each approximation of the survey costs and saves: for every approximation and its exact counterpart, the time
// per evaluation (both benchmarked in this process; the ratio is reported as the counter speed_ratio = exact ns /
// approximation ns, > 1 when the approximation is faster), the relative error of the approximated term over a dense
// grid of angles and parameters, and the error it causes in the directional albedo E(μ) = ∫ f cos θ_i dω_i of a
// model using it. After the benchmarks a Markdown table of all of this is printed (and written to --table_out=FILE).
//
//   approximations_bench [--table_out=FILE] [Google Benchmark flags]
//
// Albedo errors are max over the grid of |E_approx − E_exact|, both from brdf::directional_albedo with the same seed
// and the same sampler (a Beckmann/GGX mixture for the microfacet models, see MixtureSampled; cosine sampling for
// Oren–Nayar), so both models of a pair see the same directions and the difference has much less noise than either
// estimate; the notes give the conservative bound SE_a + SE_e on its noise.
//
// Timings are CPU time per evaluation, the fastest of 5 repetitions (the machine may be shared). The error
// measurements do not depend on timing and are deterministic.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "bakers/brdf/albedo.h"
#include "bakers/brdf/fresnel.h"
#include "bakers/brdf/microfacet.h"
#include "bakers/brdf/microfacet_distribution.h"
#include "bakers/brdf/model_spec.h"
#include "bakers/brdf/oren_nayar.h"
#include "bakers/math/constants.h"
#include "bakers/math/rng.h"
#include "bakers/math/sampling.h"
#include "tests/bench/table_file.h"

namespace kiln::brdf {
namespace {

constexpr double kDeg = kPi / 180.0;
// Inputs per benchmark iteration: enough to defeat branch-predictor memorisation of one input, small enough for L2.
constexpr int kInputs = 1024;

Vec3 spherical(double theta, double phi) {
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

// ------------------------------------------------------------------------------------------------------------------
// Inputs, drawn once with a fixed seed.

struct DirectionPair {
  Vec3 wo, wi, wh;
};
std::vector<DirectionPair> random_pairs(uint64_t seed) {
  Pcg32 rng(seed);
  std::vector<DirectionPair> out;
  while (static_cast<int>(out.size()) < kInputs) {
    const Vec3 wo = sample_cosine_hemisphere({rng.uniform(), rng.uniform()});
    const Vec3 wi = sample_cosine_hemisphere({rng.uniform(), rng.uniform()});
    if (wo.z > 0 && wi.z > 0) out.push_back({wo, wi, normalize(wo + wi)});
  }
  return out;
}

struct Inputs {
  std::vector<double> cosines, etas, f0s;  // Fresnel
  std::vector<Vec3> beckmann_normals;      // D: normals drawn from Beckmann α = 0.3 (where D matters)
  std::vector<Vec3> directions;            // G1
  std::vector<int> alpha_index;            // G1: which α of kG1Alphas
  std::vector<DirectionPair> pairs;        // Oren–Nayar, Smith G, V-groove
};
const std::vector<double> kG1Alphas = {0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 0.85, 1.0};

const Inputs& inputs() {
  static const Inputs in = [] {
    Inputs r;
    Pcg32 rng(2024);
    const MicrofacetDistribution beckmann(Distribution::beckmann, 0.3, 0.3);
    for (int i = 0; i < kInputs; ++i) {
      const double c = 1.0 - rng.uniform();  // (0, 1]
      const double eta = 1.2 + 1.3 * rng.uniform();
      r.cosines.push_back(c);
      r.etas.push_back(eta);
      r.f0s.push_back(f0_from_eta(eta));
      r.beckmann_normals.push_back(beckmann.sample_wh({0, 0, 1}, {rng.uniform(), rng.uniform()}));
      r.directions.push_back(sample_uniform_hemisphere({rng.uniform(), rng.uniform()}));
      r.alpha_index.push_back(static_cast<int>(rng.next_u32() % kG1Alphas.size()));
    }
    r.pairs = random_pairs(99);
    return r;
  }();
  return in;
}

// ------------------------------------------------------------------------------------------------------------------
// The timed evaluations. Each loop runs over the whole input array and hands every result to DoNotOptimize, so the
// compiler can neither drop the evaluation nor hoist it out of the loop (the inputs change per element).

template <typename F>
void run_loop(benchmark::State& state, F&& eval_one) {
  for (auto _ : state) {
    for (int i = 0; i < kInputs; ++i) {
      double v = eval_one(i);
      benchmark::DoNotOptimize(v);
    }
  }
  state.SetItemsProcessed(state.iterations() * kInputs);
}

MicrofacetBrdf make_microfacet(Distribution d, Masking m, double alpha) {
  MicrofacetParams p;
  p.distribution = d;
  p.masking = m;
  p.alpha_x = p.alpha_y = alpha;
  return MicrofacetBrdf(p);
}

// One approximation and its exact counterpart: the benchmark bodies and the error measurements.
struct Pair {
  std::string key;     // benchmark name prefix
  std::string approx;  // table labels
  std::string exact;
  std::function<void(benchmark::State&)> bench_approx, bench_exact;
  // Filled by measure().
  double max_rel = 0, mean_rel = 0, max_albedo = 0, albedo_noise = 0;
  std::string note, max_where, albedo_where, extra;
};

struct ErrorStats {
  double max = 0, sum = 0;
  long n = 0;
  std::string where;  // the grid point of the maximum
  template <typename Where>
  void add(double approx, double exact, Where&& describe) {
    const double e = std::fabs(approx - exact) / exact;
    if (e > max) {
      max = e;
      where = describe() + " (" + std::to_string(approx) + " vs " + std::to_string(exact) + ")";
    }
    sum += e;
    ++n;
  }
  double mean() const { return n ? sum / n : 0.0; }
};

std::string fmt(const char* f, double a, double b = 0, double c = 0, double d = 0) {
  char buf[160];
  std::snprintf(buf, sizeof buf, f, a, b, c, d);
  return buf;
}

// Samples wi through a half vector drawn with probability 1/2 from Beckmann's D cos θ_h and 1/2 from GGX's visible
// normals, both of width α, and evaluates the wrapped model. Both models of a pair get the same sampler, so their
// samples coincide; and the weights f cos θ_i / pdf stay bounded for every microfacet model here (GGX's heavy tail
// covers Schlick's rational D, whose tail ∝ m²/tan⁴θ_h is far heavier than Beckmann's, and the visible-normal part
// covers grazing wo). The models' own samplers would give the same expectation with far more noise in those cases.
class MixtureSampled final : public Bxdf {
 public:
  MixtureSampled(std::unique_ptr<Bxdf> model, double alpha)
      : model_(std::move(model)),
        beckmann_(Distribution::beckmann, alpha, alpha),
        ggx_(Distribution::ggx, alpha, alpha) {}
  Rgb eval(const Vec3& wo, const Vec3& wi) const override { return model_->eval(wo, wi); }
  std::optional<BsdfSample> sample(const Vec3& wo, Point2 u, double uc) const override {
    if (!(wo.z > 0) || !is_finite(wo)) return std::nullopt;
    const Vec3 wh = uc < 0.5 ? beckmann_.sample_wh(wo, u) : ggx_.sample_wh(wo, u);
    if (!(dot(wo, wh) > 0)) return std::nullopt;
    const Vec3 wi = reflect(wo, wh);
    if (!(wi.z > 0)) return std::nullopt;
    return make_sample(wi, eval(wo, wi), pdf(wo, wi));
  }
  double pdf(const Vec3& wo, const Vec3& wi) const override {
    if (!valid_reflection_pair(wo, wi)) return 0.0;
    const Vec3 wh = normalize(wo + wi);
    const double oh = dot(wo, wh);
    if (!(oh > 0)) return 0.0;
    return 0.5 * (beckmann_.pdf_wh(wo, wh) + ggx_.pdf_wh(wo, wh)) / (4.0 * oh);
  }
  std::string describe() const override { return "mixture-sampled " + model_->describe(); }

 private:
  std::unique_ptr<Bxdf> model_;
  MicrofacetDistribution beckmann_, ggx_;
};

// max over μ and the given specs of |E_approx − E_exact|, with the noise bound SE_a + SE_e at that maximum (with
// common samples the difference is positively correlated, so its standard error is at most the sum).
void albedo_error(Pair& pair, const std::vector<std::pair<ModelSpec, ModelSpec>>& specs) {
  AlbedoOptions options;
  options.samples = 16384;
  options.replicates = 8;
  options.seed = 7;
  const auto build = [](const ModelSpec& spec) -> std::unique_ptr<Bxdf> {
    const bool microfacet =
        spec.model == Model::ggx || spec.model == Model::beckmann || spec.model == Model::cook_torrance;
    if (!microfacet) return make_bxdf(spec);  // Oren–Nayar: both sample the cosine, the same directions
    return std::make_unique<MixtureSampled>(make_bxdf(spec), std::sqrt(spec.alpha_x * spec.alpha_y));
  };
  for (const auto& [approx_spec, exact_spec] : specs) {
    const auto approx = build(approx_spec), exact = build(exact_spec);
    for (double mu : {0.02, 0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 0.9, 1.0}) {
      const Estimate a = directional_albedo(*approx, mu, options), e = directional_albedo(*exact, mu, options);
      const double d = std::fabs(a.value.r - e.value.r);
      if (d > pair.max_albedo) {
        pair.max_albedo = d;
        pair.albedo_noise = a.std_error.r + e.std_error.r;
        pair.albedo_where = "μ=" + fmt("%g", mu) + ", " + exact->describe() + ": E approx " + fmt("%.4f", a.value.r) +
                            ", exact " + fmt("%.4f", e.value.r);
      }
    }
  }
}

std::vector<Pair> make_pairs() {
  std::vector<Pair> pairs;

  // --- Schlick's Fresnel (f0 from η) vs the exact dielectric Fresnel. ---
  {
    Pair p;
    p.key = "fresnel";
    p.approx = "Schlick Fresnel, f0 = ((η−1)/(η+1))²";
    p.exact = "exact dielectric Fresnel (eq 10–11)";
    p.bench_approx = [](benchmark::State& s) {
      const Inputs& in = inputs();
      run_loop(s, [&](int i) { return fresnel_schlick(in.cosines[i], in.f0s[i]); });
    };
    p.bench_exact = [](benchmark::State& s) {
      const Inputs& in = inputs();
      run_loop(s, [&](int i) { return fresnel_dielectric(in.cosines[i], in.etas[i]); });
    };
    p.note =
        "rel err over c = cos θ ∈ (0, 1] (2000 points) × η ∈ [1.1, 2.5] step 0.05 (dielectrics, η > 1); albedo: "
        "GGX, separable Smith, α ∈ {0.05, 0.1, 0.2, 0.4, 0.7, 1}, η ∈ {1.33, 1.5, 2, 2.5}";
    pairs.push_back(std::move(p));
  }
  // --- Schlick's rational Beckmann D vs Beckmann. ---
  {
    Pair p;
    p.key = "beckmann_d";
    p.approx = "Schlick rational Beckmann D (eq 20)";
    p.exact = "Beckmann D";
    p.bench_approx = [](benchmark::State& s) {
      const Inputs& in = inputs();
      const MicrofacetDistribution d(Distribution::schlick_beckmann, 0.3, 0.3);
      run_loop(s, [&](int i) { return d.D(in.beckmann_normals[i]); });
    };
    p.bench_exact = [](benchmark::State& s) {
      const Inputs& in = inputs();
      const MicrofacetDistribution d(Distribution::beckmann, 0.3, 0.3);
      run_loop(s, [&](int i) { return d.D(in.beckmann_normals[i]); });
    };
    p.note =
        "rel err over α ∈ [0.02, 1] step 0.02 × θ_h ∈ [0, θ_max(α)] (400 points), θ_max where Beckmann D falls "
        "to 1e-3 of its peak (tan θ_max = 2.63 α; beyond it the rational D is 0 for cos θ_h < 1 − α); albedo: "
        "Beckmann with separable Smith, α ∈ {0.05, 0.1, 0.2, 0.4, 0.7, 1}";
    pairs.push_back(std::move(p));
  }
  // --- Schlick's G1 vs the exact Smith–Beckmann G1. ---
  {
    Pair p;
    p.key = "g1";
    p.approx = "Schlick G1 (eq 19)";
    p.exact = "Smith–Beckmann G1 = 1/(1+Λ)";
    p.bench_approx = [](benchmark::State& s) {
      const Inputs& in = inputs();
      run_loop(s, [&](int i) { return g1_schlick(in.directions[i].z, kG1Alphas[in.alpha_index[i]]); });
    };
    p.bench_exact = [](benchmark::State& s) {
      const Inputs& in = inputs();
      std::vector<MicrofacetDistribution> d;
      for (double a : kG1Alphas) d.emplace_back(Distribution::beckmann, a, a);
      run_loop(s, [&](int i) { return d[in.alpha_index[i]].G1(in.directions[i]); });
    };
    p.note =
        "rel err over α ∈ [0.01, 1] step 0.01 × θ ∈ [0°, 89.9°] step 0.1°; albedo: Beckmann D, G = product of the "
        "two G1, α ∈ {0.05, 0.1, 0.2, 0.4, 0.7, 1}";
    pairs.push_back(std::move(p));
  }
  // --- Simplified vs full Oren–Nayar. ---
  {
    Pair p;
    p.key = "oren_nayar";
    p.approx = "simplified Oren–Nayar (A, B; eq 27)";
    p.exact = "full first-order Oren–Nayar (C1, C2, C3)";
    p.bench_approx = [](benchmark::State& s) {
      const Inputs& in = inputs();
      const OrenNayarSimple on(Rgb{0.8}, 0.5);
      run_loop(s, [&](int i) { return on.eval(in.pairs[i].wo, in.pairs[i].wi).r; });
    };
    p.bench_exact = [](benchmark::State& s) {
      const Inputs& in = inputs();
      const OrenNayar on(Rgb{0.8}, 0.5, false);
      run_loop(s, [&](int i) { return on.eval(in.pairs[i].wo, in.pairs[i].wi).r; });
    };
    p.note =
        "rel err over σ ∈ [0.05, 1] rad step 0.05 × θ_o, θ_i ∈ [0°, 88°] step 2° × Δφ ∈ [0, π] step π/18, where "
        "the full model is ≥ 1 % of ρ/π (it is clamped at 0 for σ > 0.664 near the horizon); no interreflection "
        "term; albedo (ρ = 1): σ ∈ {0.1, 0.25, 0.5, 0.75, 1}";
    pairs.push_back(std::move(p));
  }
  // --- Separable vs height-correlated Smith (GGX). ---
  {
    Pair p;
    p.key = "smith_ggx";
    p.approx = "separable Smith G1(o)G1(i), GGX";
    p.exact = "height-correlated Smith 1/(1+Λo+Λi), GGX";
    p.bench_approx = [](benchmark::State& s) {
      const Inputs& in = inputs();
      const MicrofacetBrdf b = make_microfacet(Distribution::ggx, Masking::separable, 0.3);
      run_loop(s, [&](int i) { return b.G(in.pairs[i].wo, in.pairs[i].wi, in.pairs[i].wh); });
    };
    p.bench_exact = [](benchmark::State& s) {
      const Inputs& in = inputs();
      const MicrofacetBrdf b = make_microfacet(Distribution::ggx, Masking::height_correlated, 0.3);
      run_loop(s, [&](int i) { return b.G(in.pairs[i].wo, in.pairs[i].wi, in.pairs[i].wh); });
    };
    p.note =
        "rel err over α ∈ [0.02, 1] step 0.02 × θ_o, θ_i ∈ [0°, 89.5°] step 0.5°; albedo: GGX, no Fresnel, "
        "α ∈ {0.05, 0.1, 0.2, 0.4, 0.7, 1}";
    pairs.push_back(std::move(p));
  }
  // --- V-groove vs Smith (Beckmann). ---
  {
    Pair p;
    p.key = "vgroove";
    p.approx = "V-groove G (eq 12)";
    p.exact = "height-correlated Smith, Beckmann";
    p.bench_approx = [](benchmark::State& s) {
      const Inputs& in = inputs();
      run_loop(s, [&](int i) { return g_vgroove(in.pairs[i].wo, in.pairs[i].wi, in.pairs[i].wh); });
    };
    p.bench_exact = [](benchmark::State& s) {
      const Inputs& in = inputs();
      const MicrofacetBrdf b = make_microfacet(Distribution::beckmann, Masking::height_correlated, 0.3);
      run_loop(s, [&](int i) { return b.G(in.pairs[i].wo, in.pairs[i].wi, in.pairs[i].wh); });
    };
    p.note =
        "rel err over α ∈ [0.05, 1] step 0.05 × θ_o, θ_i ∈ [0°, 88°] step 2° × Δφ ∈ [0, π] step π/18 (V-groove "
        "does not depend on α); albedo: Beckmann D, no Fresnel, α ∈ {0.05, 0.1, 0.2, 0.4, 0.7, 1}";
    pairs.push_back(std::move(p));
  }
  return pairs;
}

const std::vector<double> kAlbedoAlphas = {0.05, 0.1, 0.2, 0.4, 0.7, 1.0};

ModelSpec microfacet_spec(Model model, double alpha) {
  ModelSpec s;
  s.model = model;
  s.alpha_x = s.alpha_y = alpha;
  return s;
}

// The error measurements, one per pair (by key).
void measure(Pair& p) {
  if (p.key == "fresnel") {
    ErrorStats st;
    for (int k = 0; k <= 28; ++k) {
      const double eta = 1.1 + 0.05 * k;
      const double f0 = f0_from_eta(eta);
      for (int i = 0; i < 2000; ++i) {
        const double c = (i + 0.5) / 2000.0;
        st.add(fresnel_schlick(c, f0), fresnel_dielectric(c, eta), [&] { return fmt("c=%.4f, η=%.2f", c, eta); });
      }
    }
    p.max_rel = st.max, p.mean_rel = st.mean(), p.max_where = st.where;
    std::vector<std::pair<ModelSpec, ModelSpec>> specs;
    for (double alpha : kAlbedoAlphas) {
      for (double eta : {1.33, 1.5, 2.0, 2.5}) {
        ModelSpec a = microfacet_spec(Model::ggx, alpha), e = a;
        a.fresnel = FresnelMode::schlick;
        a.f0 = Rgb{f0_from_eta(eta)};
        e.fresnel = FresnelMode::exact;
        e.eta = eta;
        specs.push_back({a, e});
      }
    }
    albedo_error(p, specs);
  } else if (p.key == "beckmann_d") {
    ErrorStats st;
    double weighted = 0, weight = 0;
    for (int k = 1; k <= 50; ++k) {
      const double alpha = 0.02 * k;
      const MicrofacetDistribution approx(Distribution::schlick_beckmann, alpha, alpha);
      const MicrofacetDistribution exact(Distribution::beckmann, alpha, alpha);
      const double theta_max = std::atan(2.63 * alpha);
      for (int i = 0; i < 400; ++i) {
        const double theta = theta_max * (i + 0.5) / 400.0;
        const Vec3 h = spherical(theta, 0.3);
        const double a = approx.D(h), e = exact.D(h);
        st.add(a, e, [&] { return fmt("α=%.2f, θ_h=%.2f°", alpha, theta / kDeg); });
        // The same error weighted by where the exact lobe is (D cos θ_h dω_h ∝ D cos θ sin θ dθ).
        const double w = e * std::cos(theta) * std::sin(theta);
        weighted += w * std::fabs(a - e) / e;
        weight += w;
      }
    }
    p.max_rel = st.max, p.mean_rel = st.mean(), p.max_where = st.where;
    p.extra = "mean rel err weighted by the exact lobe D cos θ_h dω_h: " + fmt("%.3g", weighted / weight);
    std::vector<std::pair<ModelSpec, ModelSpec>> specs;
    for (double alpha : kAlbedoAlphas) {
      ModelSpec a = microfacet_spec(Model::beckmann, alpha), e = a;
      a.distribution = Distribution::schlick_beckmann;
      specs.push_back({a, e});
    }
    albedo_error(p, specs);
  } else if (p.key == "g1") {
    ErrorStats st;
    for (int k = 1; k <= 100; ++k) {
      const double alpha = 0.01 * k;
      const MicrofacetDistribution exact(Distribution::beckmann, alpha, alpha);
      for (int i = 0; i < 900; ++i) {
        const Vec3 w = spherical(0.1 * i * kDeg, 0.0);
        st.add(g1_schlick(w.z, alpha), exact.G1(w), [&] { return fmt("α=%.2f, θ=%.1f°", alpha, 0.1 * i); });
      }
    }
    p.max_rel = st.max, p.mean_rel = st.mean(), p.max_where = st.where;
    std::vector<std::pair<ModelSpec, ModelSpec>> specs;
    for (double alpha : kAlbedoAlphas) {
      ModelSpec a = microfacet_spec(Model::beckmann, alpha), e = a;
      a.masking = Masking::schlick;
      e.masking = Masking::separable;
      specs.push_back({a, e});
    }
    albedo_error(p, specs);
  } else if (p.key == "oren_nayar") {
    ErrorStats st;
    long skipped = 0;
    for (int k = 1; k <= 20; ++k) {
      const double sigma = 0.05 * k;
      const OrenNayarSimple approx(Rgb{1.0}, sigma);
      const OrenNayar exact(Rgb{1.0}, sigma, false);
      for (int io = 0; io <= 44; ++io) {
        for (int ii = 0; ii <= 44; ++ii) {
          for (int ip = 0; ip <= 18; ++ip) {
            const Vec3 wo = spherical(2.0 * io * kDeg, 0.0), wi = spherical(2.0 * ii * kDeg, ip * kPi / 18.0);
            const double e = exact.eval(wo, wi).r;
            // Relative error only where the full model is at least 1 % of Lambert's ρ/π: it is clamped at 0 near
            // the horizon for σ > 0.664, and relative errors against ~0 say nothing.
            if (e >= 0.01 * kInvPi) {
              st.add(approx.eval(wo, wi).r, e,
                     [&] { return fmt("σ=%.2f, θo=%g°, θi=%g°, Δφ=%g°", sigma, 2.0 * io, 2.0 * ii, 10.0 * ip); });
            } else {
              ++skipped;
            }
          }
        }
      }
    }
    p.max_rel = st.max, p.mean_rel = st.mean(), p.max_where = st.where;
    p.extra = fmt("%.0f of %.0f grid points skipped (full model < 1 %% of ρ/π)", skipped, skipped + st.n);
    std::vector<std::pair<ModelSpec, ModelSpec>> specs;
    for (double sigma : {0.1, 0.25, 0.5, 0.75, 1.0}) {
      ModelSpec a;
      a.model = Model::oren_nayar_simple;
      a.albedo = Rgb{1.0};
      a.sigma = sigma;
      ModelSpec e = a;
      e.model = Model::oren_nayar;
      specs.push_back({a, e});
    }
    albedo_error(p, specs);
  } else if (p.key == "smith_ggx") {
    ErrorStats st;
    for (int k = 1; k <= 50; ++k) {
      const double alpha = 0.02 * k;
      const MicrofacetBrdf approx = make_microfacet(Distribution::ggx, Masking::separable, alpha);
      const MicrofacetBrdf exact = make_microfacet(Distribution::ggx, Masking::height_correlated, alpha);
      for (int io = 0; io < 180; ++io) {
        for (int ii = 0; ii < 180; ++ii) {
          // Smith's G of an isotropic D depends on θ_o and θ_i only; Δφ = 2 rad is a generic configuration.
          const Vec3 wo = spherical(0.5 * io * kDeg, 0.0), wi = spherical(0.5 * ii * kDeg, 2.0);
          const Vec3 wh = normalize(wo + wi);
          st.add(approx.G(wo, wi, wh), exact.G(wo, wi, wh),
                 [&] { return fmt("α=%.2f, θo=%.1f°, θi=%.1f°", alpha, 0.5 * io, 0.5 * ii); });
        }
      }
    }
    p.max_rel = st.max, p.mean_rel = st.mean(), p.max_where = st.where;
    std::vector<std::pair<ModelSpec, ModelSpec>> specs;
    for (double alpha : kAlbedoAlphas) {
      ModelSpec a = microfacet_spec(Model::ggx, alpha), e = a;
      a.masking = Masking::separable;
      e.masking = Masking::height_correlated;
      specs.push_back({a, e});
    }
    albedo_error(p, specs);
  } else if (p.key == "vgroove") {
    ErrorStats st;
    for (int k = 1; k <= 20; ++k) {
      const double alpha = 0.05 * k;
      const MicrofacetBrdf exact = make_microfacet(Distribution::beckmann, Masking::height_correlated, alpha);
      for (int io = 0; io <= 44; ++io) {
        for (int ii = 0; ii <= 44; ++ii) {
          for (int ip = 0; ip <= 18; ++ip) {
            const Vec3 wo = spherical(2.0 * io * kDeg, 0.0), wi = spherical(2.0 * ii * kDeg, ip * kPi / 18.0);
            const Vec3 wh = normalize(wo + wi);
            st.add(g_vgroove(wo, wi, wh), exact.G(wo, wi, wh),
                   [&] { return fmt("α=%.2f, θo=%g°, θi=%g°, Δφ=%g°", alpha, 2.0 * io, 2.0 * ii, 10.0 * ip); });
          }
        }
      }
    }
    p.max_rel = st.max, p.mean_rel = st.mean(), p.max_where = st.where;
    std::vector<std::pair<ModelSpec, ModelSpec>> specs;
    for (double alpha : kAlbedoAlphas) {
      ModelSpec a = microfacet_spec(Model::beckmann, alpha), e = a;
      a.masking = Masking::v_groove;
      e.masking = Masking::height_correlated;
      specs.push_back({a, e});
    }
    albedo_error(p, specs);
  }
}

// ------------------------------------------------------------------------------------------------------------------
// A console reporter that also records ns per evaluation, and adds speed_ratio = exact / approx to each approximation
// (its exact counterpart is registered, and so run and reported, just before it).

std::map<std::string, double> g_ns_per_eval;

class RatioReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& reports) override {
    // All repetitions of one benchmark arrive together. The figure kept is the fastest repetition: on a shared
    // machine interference only ever adds time, so the minimum is the most reproducible estimate of the code's cost.
    std::vector<Run> out = reports;
    std::string name;
    double best = INFINITY;
    for (Run& run : out) {
      if (run.run_type != Run::RT_Iteration || run.error_occurred || run.iterations == 0) continue;
      // The registered name ("fresnel/exact"), without the "/min_time:..." decoration.
      name = run.run_name.function_name;
      // CPU time rather than wall time: the machine is shared, and a descheduled thread is not the code's cost.
      const double ns = run.cpu_accumulated_time / static_cast<double>(run.iterations) / kInputs * 1e9;
      run.counters["ns_per_eval"] = benchmark::Counter(ns);
      best = std::min(best, ns);
    }
    if (!name.empty()) {
      g_ns_per_eval[name] = best;
      const std::string suffix = "/approx";
      if (name.size() > suffix.size() && name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0) {
        const auto exact = g_ns_per_eval.find(name.substr(0, name.size() - suffix.size()) + "/exact");
        if (exact != g_ns_per_eval.end()) {
          for (Run& run : out) {
            if (run.run_type == Run::RT_Iteration)
              run.counters["speed_ratio"] = benchmark::Counter(exact->second / best);
          }
        }
      }
    }
    ConsoleReporter::ReportRuns(out);
  }
};

std::string format(const char* fmt, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, v);
  return buf;
}
std::string ns_cell(const std::string& name) {
  const auto it = g_ns_per_eval.find(name);
  return it == g_ns_per_eval.end() ? "—" : format("%.2f", it->second);
}

std::string table(const std::vector<Pair>& pairs, const std::string& command) {
  std::string t;
  t += "| approximation | exact | ns/eval approx | ns/eval exact | speed ratio | max rel err | mean rel err | "
       "max albedo err |\n";
  t += "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |\n";
  for (const Pair& p : pairs) {
    const auto a = g_ns_per_eval.find(p.key + "/approx"), e = g_ns_per_eval.find(p.key + "/exact");
    const std::string ratio =
        (a != g_ns_per_eval.end() && e != g_ns_per_eval.end()) ? format("%.2f×", e->second / a->second) : "—";
    t += "| " + p.approx + " | " + p.exact + " | " + ns_cell(p.key + "/approx") + " | " + ns_cell(p.key + "/exact") +
         " | " + ratio + " | " + format("%.3g", p.max_rel) + " | " + format("%.3g", p.mean_rel) + " | " +
         format("%.2e", p.max_albedo) + " |\n";
  }
  t += "\nSpeed ratio = ns/eval exact ÷ ns/eval approx (> 1: the approximation is faster), both timed in the same "
       "process over the same 1024 inputs. Relative error = |approx − exact| / exact. Max albedo err = max over μ = "
       "cos θ_o ∈ {0.02, 0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 0.9, 1} and the parameters listed of |E_approx − E_exact| "
       "(white, ρ = 1 or no Fresnel unless stated), by brdf::directional_albedo with 16384 stratified samples per "
       "estimate and the same seed for both; microfacet models are sampled through a Beckmann/GGX-visible-normal "
       "mixture "
       "(the same for both models of a pair), Oren–Nayar by its cosine sampling. ns/eval is CPU time, the fastest of 5 "
       "repetitions.\n\n";
  for (const Pair& p : pairs) {
    t += "- **" + p.approx + "**: " + p.note + ". Max rel err at " + p.max_where + "." +
         (p.extra.empty() ? "" : " " + p.extra + ".") + " Max albedo err at " + p.albedo_where + " (noise bound " +
         format("%.1e", p.albedo_noise) + ").\n";
  }
  t += "\nRegenerate with (after `cmake --build <build dir> --target approximations_bench`, RelWithDebInfo = -O2): `" +
       command + "`\n";
  return t;
}

}  // namespace
}  // namespace kiln::brdf

int main(int argc, char** argv) {
  using namespace kiln::brdf;
  // Our own flag first; Google Benchmark rejects flags it does not know.
  std::string table_out;
  std::string command = argv[0];
  int kept = 1;
  for (int i = 1; i < argc; ++i) {
    if (std::strncmp(argv[i], "--table_out=", 12) == 0) {
      table_out = argv[i] + 12;
      command += " --table_out=" + table_out;
    } else {
      command += std::string(" ") + argv[i];
      argv[kept++] = argv[i];
    }
  }
  argc = kept;
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;

  std::vector<Pair> pairs = make_pairs();
  for (Pair& p : pairs) {
    // Exact first: its time is what the approximation's speed_ratio is computed against.
    // 5 repetitions of 0.1 s each: the table keeps the fastest (see RatioReporter); about 12 s in all.
    benchmark::RegisterBenchmark((p.key + "/exact").c_str(), p.bench_exact)->MinTime(0.1)->Repetitions(5);
    benchmark::RegisterBenchmark((p.key + "/approx").c_str(), p.bench_approx)->MinTime(0.1)->Repetitions(5);
  }
  RatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();

  std::printf("\nmeasuring errors...\n");
  for (Pair& p : pairs) measure(p);
  const std::string t = table(pairs, command);
  std::printf("\n%s", t.c_str());
  return kiln::bench::write_table_file(t, table_out);
}
