#include "bakers/material/material_bake.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <mutex>
#include <set>
#include <utility>

#include "bakers/bake/number_format.h"
#include "bakers/brdf/fresnel.h"
#include "bakers/image/exr.h"
#include "bakers/material/material_report.h"
#include "bakers/material/merl.h"
#include "bakers/material/number_text.h"
#include "bakers/math/constants.h"
#include "bakers/math/rng.h"
#include "bakers/math/sampling.h"

namespace kiln::material {
namespace {

using Clock = std::chrono::steady_clock;
using brdf::Estimate;

constexpr int kMaxTable = 1024;
constexpr uint64_t kMaxSamples = uint64_t{1} << 30;
constexpr uint64_t kDefaultSamples = 4096;
constexpr uint64_t kDefaultCap = uint64_t{1} << 20;  // per entry when only target_error is given
constexpr uint64_t kFirstRound = 1024;               // first pass of a progressive bake
constexpr uint64_t kMaxBlock = 65536;                // samples between two cancel checks (a few ms)
constexpr int kReplicates = 8;                       // as brdf::AlbedoOptions: 7 degrees of freedom per block
constexpr int kReciprocityPairs = 4096;
constexpr int kApproximationSamples = 8192;  // per μ; both sides share their samples, so differences are precise
// Odd: anisotropic lobes are usually unchanged by turning the whole configuration by π, which would pair up an
// even count of evenly spaced azimuths; 7 of them act like 14 over [0, π).
constexpr int kMerlAnisotropicAzimuths = 7;

uint64_t splitmix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}
// Every block of every entry gets its own seed, so that rounds are independent and the bake is reproducible.
uint64_t block_seed(uint64_t seed, uint64_t entry, uint64_t block) {
  return splitmix64(splitmix64(seed) ^ splitmix64((entry << 24) + block));
}

Vec3 direction_from(double mu, double phi) {
  const double s = std::sqrt(std::fmax(0.0, 1.0 - mu * mu));
  return {s * std::cos(phi), s * std::sin(phi), mu};
}

// The estimator of brdf/albedo.cpp (independent replicates of n×n jittered strata; their spread gives the standard
// error), for the integrals that library offers only as whole tables: one split-sum entry, the average albedo.
// One stratified estimate of `samples` samples: the albedo library's estimator, so both count and combine alike.
Estimate stratified(uint64_t samples, uint64_t seed, uint64_t stream, const brdf::SampleContribution& contribution) {
  brdf::AlbedoOptions o;
  o.samples = static_cast<int>(samples);
  o.replicates = kReplicates;
  o.seed = seed;
  return brdf::stratified_estimate(o, stream, contribution);
}

// Samples an estimate of `requested` samples really takes: whole replicates of n×n strata.
uint64_t taken(uint64_t requested) {
  brdf::AlbedoOptions o;
  o.samples = static_cast<int>(requested);
  o.replicates = kReplicates;
  return static_cast<uint64_t>(brdf::stratified_sample_count(o));
}
// Samples taken for `requested` in blocks of at most kMaxBlock.
uint64_t taken_in_blocks(uint64_t requested) {
  uint64_t total = 0;
  for (; requested > kMaxBlock; requested -= kMaxBlock) total += taken(kMaxBlock);
  return total + (requested ? taken(requested) : 0);
}

Rgb sqrt_rgb(const Rgb& c) { return {std::sqrt(c.r), std::sqrt(c.g), std::sqrt(c.b)}; }

// --- Table entries and their rounds. ----------------------------------------------------------------------------

enum class Kind { albedo, white, average, white_average, split_sum };

struct Entry {
  Kind kind = Kind::albedo;
  int i_mu = 0, i_roughness = 0;
  uint64_t requested = 0;    // samples asked for so far (before rounding up to whole replicates)
  uint64_t samples = 0;      // samples taken
  Rgb weighted_sum;          // Σ n_k m_k
  Rgb weighted_variance;     // Σ n_k² se_k²
  double planned = 0;        // samples this entry is expected to need in total (for progress)
  bool done = false;

  Rgb mean() const { return samples ? weighted_sum / static_cast<double>(samples) : Rgb{}; }
  Rgb std_error() const {
    return samples ? sqrt_rgb(weighted_variance) / static_cast<double>(samples) : Rgb{};
  }
  // Split-sum entries carry scale in r and bias in g; b is unused.
  double error() const {
    const Rgb se = std_error();
    return kind == Kind::split_sum ? std::max(se.r, se.g) : se.max();
  }
  void add(const Estimate& e) {
    const double n = static_cast<double>(e.samples);
    weighted_sum += e.value * n;
    weighted_variance += e.std_error * e.std_error * (n * n);
    samples += static_cast<uint64_t>(e.samples);
  }
};

// Serialises progress reports, keeps the fraction monotone, and answers "cancelled?".
class Progress {
 public:
  Progress(const bake::BakeControl& control, Clock::time_point start) : control_(control), start_(start) {}

  void check_cancel() const {
    if (control_.cancel && control_.cancel->load(std::memory_order_relaxed)) throw bake::BakeCancelled();
  }
  void add_planned(double units) {
    std::lock_guard lock(mutex_);
    planned_ += units;
  }
  // One step done: `units` of work (samples or evaluations), `samples` of them Monte Carlo samples. When an entry's
  // error changed, pass its old and new value (-1: none, e.g. before the first estimate).
  void step(const std::string& stage, double units, uint64_t samples, double planned_delta = 0,
            double old_error = -1, double new_error = -1) {
    // NaN would break the set's ordering; it sorts as the worst error instead (and the bake rejects it later).
    const auto key = [](double e) { return std::isnan(e) ? HUGE_VAL : e; };
    std::lock_guard lock(mutex_);
    done_ += units;
    planned_ += planned_delta;
    samples_ += samples;
    if (old_error >= 0 || std::isnan(old_error)) {
      const auto it = errors_.find(key(old_error));
      if (it != errors_.end()) errors_.erase(it);
    }
    if (new_error >= 0 || std::isnan(new_error)) errors_.insert(key(new_error));
    report(stage, false);
  }
  void finish() {
    std::lock_guard lock(mutex_);
    report("done", true);
  }
  uint64_t samples() const {
    std::lock_guard lock(mutex_);
    return samples_;
  }

 private:
  void report(const std::string& stage, bool last) {
    // Below 1 until the very end: the planned work of a progressive bake is only a forecast.
    const double f = last ? 1.0 : std::min(0.999, planned_ > 0 ? done_ / planned_ : 0.0);
    fraction_ = std::max(fraction_, f);
    if (!control_.progress) return;
    bake::BakeProgress p;
    p.fraction = fraction_;
    const double elapsed = std::chrono::duration<double>(Clock::now() - start_).count();
    p.eta_seconds = last ? 0.0 : (fraction_ > 0 ? elapsed * (1.0 - fraction_) / fraction_ : -1.0);
    p.samples = samples_;
    p.error_estimate = errors_.empty() ? 0.0 : *errors_.rbegin();
    p.stage = stage;
    control_.progress(p);
  }

  const bake::BakeControl& control_;
  Clock::time_point start_;
  mutable std::mutex mutex_;
  double done_ = 0, planned_ = 0, fraction_ = 0;
  uint64_t samples_ = 0;
  std::multiset<double> errors_;
};

// --- Input checks. ------------------------------------------------------------------------------------------------

bool has_roughness(brdf::Model m) { return std::string(brdf::roughness_name(m)) != "none"; }
bool is_microfacet(brdf::Model m) {
  return m == brdf::Model::ggx || m == brdf::Model::beckmann || m == brdf::Model::cook_torrance;
}
bool anisotropic(const brdf::ModelSpec& s) {
  if (is_microfacet(s.model)) return s.alpha_x != s.alpha_y;
  if (s.model == brdf::Model::schlick) return s.layer.p < 1;
  if (s.model == brdf::Model::schlick_double) return s.layer.p < 1 || s.bottom_layer.p < 1;
  return false;
}

// --- Approximations the model uses, each with the exact form to compare against. ------------------------------------

struct Comparison {
  std::string name;
  // One exact model per channel (the same one three times when the channels agree).
  std::vector<brdf::ModelSpec> exact;  // size 1 or 3
};

std::vector<Comparison> approximations(const brdf::ModelSpec& spec, std::vector<std::string>& plan) {
  std::vector<Comparison> out;
  const auto add = [&](const std::string& name, const brdf::ModelSpec& exact) {
    if (brdf::validate(exact)) return;  // the exact form cannot be built for these parameters
    out.push_back({name, {exact}});
  };
  if (is_microfacet(spec.model)) {
    if (brdf::fresnel_mode(spec) == brdf::FresnelMode::schlick) {
      // The dielectric whose normal reflectance is f0: eta = (1 + √f0) / (1 − √f0). The exact Fresnel accepts
      // eta ≤ 10, i.e. f0 ≤ 0.669; beyond that f0 describes a metal, for which a dielectric is no reference.
      const double f0_max = brdf::f0_from_eta(10.0);
      if (spec.f0.max() <= f0_max) {
        Comparison c{"fresnel: schlick vs exact dielectric (eta from f0 per channel)", {}};
        const bool grey = spec.f0.r == spec.f0.g && spec.f0.g == spec.f0.b;
        for (int ch = 0; ch < (grey ? 1 : 3); ++ch) {
          brdf::ModelSpec exact = spec;
          exact.fresnel = brdf::FresnelMode::exact;
          const double s = std::sqrt(spec.f0[ch]);
          exact.eta = (1.0 + s) / (1.0 - s);
          c.exact.push_back(exact);
        }
        if (std::none_of(c.exact.begin(), c.exact.end(), [](const auto& x) { return brdf::validate(x).has_value(); }))
          out.push_back(std::move(c));
      } else {
        plan.push_back("approximation fresnel schlick vs exact: skipped, f0 " + bake::format_rgb(spec.f0) +
                       " is beyond any dielectric (eta > 10); a metal needs a complex index for its exact Fresnel");
      }
    }
    const brdf::Distribution d = spec.distribution.value_or(
        spec.model == brdf::Model::ggx ? brdf::Distribution::ggx : brdf::Distribution::beckmann);
    if (d == brdf::Distribution::schlick_beckmann) {
      brdf::ModelSpec exact = spec;
      exact.distribution = brdf::Distribution::beckmann;
      add("distribution: schlick rational beckmann vs exact beckmann", exact);
    }
    const brdf::Masking m = spec.masking.value_or(spec.model == brdf::Model::cook_torrance
                                                      ? brdf::Masking::v_groove
                                                      : brdf::Masking::separable);
    if (m == brdf::Masking::separable) {
      brdf::ModelSpec exact = spec;
      exact.masking = brdf::Masking::height_correlated;
      add("masking: separable smith vs height-correlated smith", exact);
    } else if (m == brdf::Masking::schlick) {
      brdf::ModelSpec exact = spec;
      exact.masking = brdf::Masking::separable;
      add("masking: schlick rational G1 vs smith G1 from D (separable)", exact);
    }
    if (spec.normalization == brdf::Normalization::pi) {
      brdf::ModelSpec exact = spec;
      exact.normalization = brdf::Normalization::four;
      add("normalization: pi (survey eq 9) vs 4 (half-vector Jacobian)", exact);
    }
  }
  if (spec.model == brdf::Model::oren_nayar_simple) {
    brdf::ModelSpec exact = spec;
    exact.model = brdf::Model::oren_nayar;
    exact.interreflection = false;
    add("oren-nayar: simplified A/B vs full first-order (C1, C2, C3)", exact);
  }
  return out;
}

void check_finite(const Estimate& e, const std::string& what) {
  if (!e.value.is_finite() || !e.std_error.is_finite()) {
    throw std::runtime_error("material bake: the estimate of " + what +
                             " is not finite; this is a bug in the model, please report it with the model "
                             "parameters");
  }
}

}  // namespace

std::optional<bake::InvalidInput> validate(const MaterialBakeInput& in) {
  using bake::InvalidInput;
  if (in.material) {
    return InvalidInput("material",
                        "two-lobe materials are not supported by the material bake yet; describe one model in model");
  }
  if (auto e = brdf::validate(in.model)) return e->under("model");
  if (in.table_mu < 1 || in.table_mu > kMaxTable) {
    return InvalidInput("table_mu",
                        "must be in [1, " + std::to_string(kMaxTable) + "], got " + std::to_string(in.table_mu));
  }
  if (in.table_roughness < 1 || in.table_roughness > kMaxTable) {
    return InvalidInput("table_roughness", "must be in [1, " + std::to_string(kMaxTable) + "], got " +
                                               std::to_string(in.table_roughness));
  }
  if (in.samples > kMaxSamples) {
    return InvalidInput("samples", "must be at most " + std::to_string(kMaxSamples) + " per table entry, got " +
                                       std::to_string(in.samples));
  }
  if (!std::isfinite(in.target_error) || in.target_error < 0) {
    return InvalidInput("target_error", "must be a finite number >= 0 (0: off), got " + shortest_number(in.target_error));
  }
  if (!std::isfinite(in.time_limit_seconds) || in.time_limit_seconds < 0) {
    return InvalidInput("time_limit_seconds",
                        "must be a finite number >= 0 (0: none), got " + shortest_number(in.time_limit_seconds));
  }
  return std::nullopt;
}

MaterialBakeResult bake_material(const MaterialBakeInput& input, const bake::BakeControl& control) {
  if (auto error = validate(input)) throw *error;
  const Clock::time_point start = Clock::now();
  const auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  Progress progress(control, start);
  progress.check_cancel();

  MaterialBakeResult result;
  std::vector<std::string>& plan = result.plan;
  const brdf::ModelSpec& spec = input.model;
  const int n_mu = input.table_mu, n_r = input.table_roughness;

  const std::unique_ptr<brdf::Bxdf> bxdf = brdf::make_bxdf(spec);
  const brdf::ModelSpec white_spec = brdf::without_fresnel(spec);
  const std::unique_ptr<brdf::Bxdf> white = brdf::make_bxdf(white_spec);
  result.description = bxdf->describe();

  // The split-sum rows: the white model at each roughness texel centre. A model without a roughness parameter
  // has one distinct row.
  const bool rough_axis = has_roughness(spec.model);
  const int distinct_rows = rough_axis ? n_r : 1;
  std::vector<double> roughness(n_r);
  for (int j = 0; j < n_r; ++j) roughness[j] = (j + 0.5) / n_r * brdf::max_roughness(spec.model);
  std::vector<std::unique_ptr<brdf::Bxdf>> rows;
  for (int j = 0; j < distinct_rows; ++j) {
    rows.push_back(brdf::make_bxdf(brdf::with_roughness(white_spec, roughness[j])));
  }

  // --- The plan. ---
  const bool target_mode = input.target_error > 0;
  const bool progressive = target_mode || input.time_limit_seconds > 0;
  // Fixed mode: goal samples per entry. Target mode: the cap.
  const uint64_t goal = input.samples ? input.samples : (target_mode ? kDefaultCap : kDefaultSamples);
  const uint64_t first_round = progressive ? std::min(goal, kFirstRound) : goal;

  plan.push_back("model: " + result.description);
  plan.push_back("albedo table: E(mu) at " + std::to_string(n_mu) +
                 " texel centres mu = (i + 0.5) / " + std::to_string(n_mu) +
                 ", model as configured, averaged over the azimuth of wo");
  plan.push_back("white-furnace table: E(mu) of " + white->describe() +
                 " (F = 1, white), for the strict energy check and energy compensation");
  if (rough_axis) {
    plan.push_back("split-sum table: " + std::to_string(n_mu) + " x " + std::to_string(n_r) + " over (mu, " +
                   brdf::roughness_name(spec.model) + " in (0, " + shortest_number(brdf::max_roughness(spec.model)) +
                   "]), white model without Fresnel, E ~= f0 * scale + bias");
  } else {
    plan.push_back("split-sum table: " + std::to_string(n_mu) + " x " + std::to_string(n_r) + "; " +
                   brdf::to_string(spec.model) + " has no roughness parameter, so one row is computed and repeated");
  }
  plan.push_back(
      "average albedo: E_avg = 2 * integral of E(mu) mu dmu, estimated directly (mu = sqrt(xi)), both forms");

  // --- Entries. ---
  std::vector<Entry> entries;
  const auto add_entry = [&](Kind kind, int i_mu, int i_roughness) {
    Entry e;
    e.kind = kind;
    e.i_mu = i_mu;
    e.i_roughness = i_roughness;
    entries.push_back(e);
  };
  for (int i = 0; i < n_mu; ++i) add_entry(Kind::albedo, i, 0);
  for (int i = 0; i < n_mu; ++i) add_entry(Kind::white, i, 0);
  add_entry(Kind::average, 0, 0);
  add_entry(Kind::white_average, 0, 0);
  for (int j = 0; j < distinct_rows; ++j)
    for (int i = 0; i < n_mu; ++i) add_entry(Kind::split_sum, i, j);
  // Forecast of each entry's samples: exact for a fixed count; the first round, to be revised, for a target.
  const auto fixed_plan = [&] {
    if (!progressive) return taken_in_blocks(goal);
    uint64_t requested = first_round, total = taken_in_blocks(first_round);
    while (requested < goal) {
      const uint64_t add = std::min(requested, goal - requested);
      total += taken_in_blocks(add);
      requested += add;
    }
    return total;
  }();
  for (Entry& e : entries) {
    e.planned = static_cast<double>(target_mode ? taken_in_blocks(first_round) : fixed_plan);
  }

  // Planned work, in samples or BRDF evaluations (they cost about the same).
  const std::vector<Comparison> comparisons = approximations(spec, plan);
  const bool merl_anisotropic = anisotropic(spec);
  const int merl_azimuths = merl_anisotropic ? kMerlAnisotropicAzimuths : 1;
  const double merl_units =
      input.merl ? static_cast<double>(kMerlEntries) * merl_azimuths * (bxdf->reciprocal() ? 1 : 2) : 0.0;
  double validation_units = 2.0 * kReciprocityPairs;
  for (const Comparison& c : comparisons) {
    validation_units +=
        static_cast<double>(1 + c.exact.size()) * n_mu * static_cast<double>(taken(kApproximationSamples));
  }
  double table_units = 0;
  for (const Entry& e : entries) table_units += e.planned;
  progress.add_planned(table_units + validation_units + merl_units);

  const double mu_of = 1.0 / n_mu;
  const auto mu_at = [&](int i) { return (i + 0.5) * mu_of; };
  const auto run_block = [&](const Entry& e, uint64_t samples, uint64_t seed) -> Estimate {
    brdf::AlbedoOptions o;
    o.samples = static_cast<int>(samples);
    o.replicates = kReplicates;
    o.seed = seed;
    switch (e.kind) {
      case Kind::albedo:
        return brdf::directional_albedo(*bxdf, mu_at(e.i_mu), o);
      case Kind::white:
        return brdf::directional_albedo(*white, mu_at(e.i_mu), o);
      case Kind::average:
      case Kind::white_average: {
        const brdf::Bxdf& b = e.kind == Kind::average ? *bxdf : *white;
        return stratified(samples, seed, 3, [&](Point2 u, double uc, Pcg32& rng) {
          const double mu = std::sqrt(1.0 - rng.uniform());  // density 2μ on (0, 1]
          const auto s = b.sample(direction_from(mu, 2.0 * kPi * rng.uniform()), u, uc);
          return s ? s->weight : Rgb{};
        });
      }
      case Kind::split_sum: {
        const brdf::Bxdf& b = *rows[e.i_roughness];
        const double mu = mu_at(e.i_mu);
        // As brdf::split_sum_table: Schlick's weight c = (1 − wo·wh)^5 splits the white albedo into scale and bias.
        return stratified(samples, seed, 4, [&](Point2 u, double uc, Pcg32& rng) {
          const Vec3 wo = direction_from(mu, 2.0 * kPi * rng.uniform());
          const auto s = b.sample(wo, u, uc);
          if (!s) return Rgb{};
          const double c = std::pow(1.0 - std::fmax(0.0, dot(wo, normalize(wo + s->wi))), 5.0);
          const double w = s->weight.average();
          return Rgb{w * (1.0 - c), w * c, 0.0};
        });
      }
    }
    return Estimate{};
  };

  // --- Passes. ---
  bool time_up = false;
  int passes = 0;
  std::vector<uint64_t> block_counter(entries.size(), 0);
  for (int pass = 0;; ++pass) {
    std::vector<size_t> active;
    for (size_t k = 0; k < entries.size(); ++k)
      if (!entries[k].done) active.push_back(k);
    if (active.empty()) break;
    if (pass > 0 && input.time_limit_seconds > 0 && elapsed() >= input.time_limit_seconds) {
      time_up = true;
      break;
    }
    ++passes;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, active.size(), 1), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t a = r.begin(); a != r.end(); ++a) {
        const size_t k = active[a];
        Entry& e = entries[k];
        // Pass 0 takes the first round; later passes double the samples, within the goal or cap.
        uint64_t want = pass == 0 ? first_round : std::min(e.requested, goal - e.requested);
        while (want > 0) {
          progress.check_cancel();
          if (pass > 0 && input.time_limit_seconds > 0 && elapsed() >= input.time_limit_seconds) break;
          const uint64_t block = std::min(want, kMaxBlock);
          const double old_error = e.samples ? e.error() : -1.0;
          const double old_planned = e.planned;
          const Estimate est = run_block(e, block, block_seed(input.seed, k, block_counter[k]++));
          e.add(est);
          e.requested += block;
          want -= block;
          const double err = e.error();
          const bool last_block = want == 0;
          if (last_block) {
            if (target_mode) {
              e.done = err <= input.target_error || e.requested >= goal;
            } else {
              e.done = e.requested >= goal;
            }
          }
          // Forecast of this entry's total: variance falls as 1/N, so N (se / target)² samples reach the target.
          if (e.done) {
            e.planned = static_cast<double>(e.samples);
          } else if (target_mode) {
            const double ratio = err / input.target_error;
            e.planned = std::min(std::max(static_cast<double>(e.samples) * ratio * ratio, 2.0 * e.samples),
                                 static_cast<double>(std::max(goal, e.samples)));
          }
          progress.step("tables", static_cast<double>(est.samples), static_cast<uint64_t>(est.samples),
                        e.planned - old_planned, old_error, err);
        }
      }
    });
    if (!progressive) break;  // fixed samples without a time limit: one pass takes them all
  }

  // --- Tables from the entries. ---
  uint64_t table_samples = 0;
  result.min_samples_per_entry = UINT64_MAX;
  int above_target = 0;
  for (const Entry& e : entries) {
    table_samples += e.samples;
    result.min_samples_per_entry = std::min(result.min_samples_per_entry, e.samples);
    result.max_samples_per_entry = std::max(result.max_samples_per_entry, e.samples);
    result.max_error_estimate = std::max(result.max_error_estimate, e.error());
    if (target_mode && e.error() > input.target_error) ++above_target;
  }
  result.samples = table_samples;
  result.target_reached = !target_mode || above_target == 0;

  const auto estimate_of = [](const Entry& e) {
    Estimate est;
    est.value = e.mean();
    est.std_error = e.std_error();
    est.samples = static_cast<int64_t>(e.samples);
    return est;
  };
  for (brdf::AlbedoTable* t : {&result.albedo, &result.white_furnace}) {
    for (int i = 0; i < n_mu; ++i) t->mu.push_back(mu_at(i));
  }
  result.split_sum.n_mu = n_mu;
  result.split_sum.n_roughness = n_r;
  for (int i = 0; i < n_mu; ++i) result.split_sum.mu.push_back(mu_at(i));
  result.split_sum.roughness = roughness;
  const size_t cells = static_cast<size_t>(n_mu) * n_r;
  result.split_sum.scale.assign(cells, 0.0);
  result.split_sum.bias.assign(cells, 0.0);
  result.split_sum.scale_error.assign(cells, 0.0);
  result.split_sum.bias_error.assign(cells, 0.0);
  for (const Entry& e : entries) {
    const Estimate est = estimate_of(e);
    switch (e.kind) {
      case Kind::albedo:
        check_finite(est, "the directional albedo at mu = " + shortest_number(mu_at(e.i_mu)));
        result.albedo.e.push_back(est);
        break;
      case Kind::white:
        check_finite(est, "the white-furnace albedo at mu = " + shortest_number(mu_at(e.i_mu)));
        result.white_furnace.e.push_back(est);
        break;
      case Kind::average:
        check_finite(est, "the average albedo");
        result.albedo.average = est;
        break;
      case Kind::white_average:
        check_finite(est, "the white-furnace average albedo");
        result.white_furnace.average = est;
        break;
      case Kind::split_sum:
        check_finite(est, "the split-sum entry at mu = " + shortest_number(mu_at(e.i_mu)));
        // Rows of a model without roughness are all the same row.
        for (int j = rough_axis ? e.i_roughness : 0; j < (rough_axis ? e.i_roughness + 1 : n_r); ++j) {
          const size_t idx = static_cast<size_t>(j) * n_mu + e.i_mu;
          result.split_sum.scale[idx] = est.value.r;
          result.split_sum.bias[idx] = est.value.g;
          result.split_sum.scale_error[idx] = est.std_error.r;
          result.split_sum.bias_error[idx] = est.std_error.g;
        }
        break;
    }
  }
  result.average_albedo = result.albedo.average.value;

  const std::string per_entry = std::to_string(result.min_samples_per_entry) +
                                (result.min_samples_per_entry == result.max_samples_per_entry
                                     ? ""
                                     : ".." + std::to_string(result.max_samples_per_entry));
  const std::string n_entries = std::to_string(entries.size());
  if (!target_mode) {
    plan.push_back("sampling: " + std::string(input.samples ? "" : "default ") + std::to_string(goal) +
                   " samples per entry requested, " + per_entry + " taken (whole stratified replicates) for " +
                   n_entries + " entries");
  } else if (result.target_reached) {
    plan.push_back("sampling: target_error " + shortest_number(input.target_error) + " reached for all " + n_entries +
                   " entries after " + per_entry + " samples per entry (" + std::to_string(passes) + " passes)");
  } else {
    plan.push_back("sampling: target_error " + shortest_number(input.target_error) + " not reached for " +
                   std::to_string(above_target) + " of " + n_entries + " entries (largest error " +
                   shortest_number(result.max_error_estimate) + ") after " + per_entry + " samples per entry: " +
                   (time_up ? "time limit reached" : "cap of " + std::to_string(goal) + " samples per entry reached"));
  }
  if (input.time_limit_seconds > 0) {
    plan.push_back("time limit " + shortest_number(input.time_limit_seconds) + " s: " +
                   (time_up ? "reached, refinement stopped after " + std::to_string(passes) + " passes"
                            : "not reached"));
  }

  // --- Validation. ---
  ValidationReport& v = result.validation;
  {
    EnergyCheck& en = v.energy;
    for (int i = 0; i < n_mu; ++i) {
      for (int c = 0; c < 3; ++c) {
        const double val = result.albedo.e[i].value[c];
        if (val > en.max_albedo || (i == 0 && c == 0)) {
          en.max_albedo = val;
          en.max_albedo_mu = mu_at(i);
          en.max_albedo_channel = c;
          en.max_albedo_error = result.albedo.e[i].std_error[c];
        }
      }
      const double w = result.white_furnace.e[i].value.max();
      if (w > en.white_max_albedo || i == 0) {
        en.white_max_albedo = w;
        en.white_max_albedo_mu = mu_at(i);
        en.white_max_albedo_error = result.white_furnace.e[i].std_error.max();
      }
    }
    en.conserves_energy = en.max_albedo <= 1.0 + 3.0 * en.max_albedo_error + 1e-9 &&
                          en.white_max_albedo <= 1.0 + 3.0 * en.white_max_albedo_error + 1e-9;
  }
  {
    ReciprocityCheck& rc = v.reciprocity;
    rc.pairs = kReciprocityPairs;
    rc.model_claims_reciprocal = bxdf->reciprocal();
    Pcg32 rng(splitmix64(input.seed) ^ 0x7265636970ULL, 5);
    for (int p = 0; p < kReciprocityPairs; ++p) {
      const Vec3 wo = sample_uniform_hemisphere({rng.uniform(), rng.uniform()});
      const Vec3 wi = sample_uniform_hemisphere({rng.uniform(), rng.uniform()});
      const Rgb a = bxdf->eval(wo, wi), b = bxdf->eval(wi, wo);
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
    progress.step("validation", 2.0 * kReciprocityPairs, 0);
    plan.push_back("reciprocity: " + std::to_string(kReciprocityPairs) +
                   " random direction pairs, uniform over the hemisphere");
  }
  for (const Comparison& cmp : comparisons) {
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
      o.seed = block_seed(input.seed, 1u << 20, static_cast<uint64_t>(i));
      approx_e[i] = brdf::directional_albedo(*bxdf, mu_at(i), o);
      Estimate per_channel[3];
      for (int c = 0; c < 3; ++c) {
        if (c > 0 && cmp.exact.size() == 1) {
          per_channel[c] = per_channel[0];
        } else {
          per_channel[c] = brdf::directional_albedo(*exact[cmp.exact.size() == 1 ? 0 : c], mu_at(i), o);
        }
      }
      exact_v[i] = {per_channel[0].value.r, per_channel[1].value.g, per_channel[2].value.b};
      exact_se[i] = {per_channel[0].std_error.r, per_channel[1].std_error.g, per_channel[2].std_error.b};
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
          ae.at_mu = mu_at(i);
          ae.std_error = std::hypot(approx_e[i].std_error[c], exact_se[i][c]);
        }
      }
      result.validation_samples += static_cast<uint64_t>(approx_e[i].samples) * (1 + cmp.exact.size());
    }
    ae.mean_abs_difference = sum / (3.0 * n_mu);
    v.approximations.push_back(ae);
    plan.push_back("approximation " + cmp.name + ": albedo difference measured at the " + std::to_string(n_mu) +
                   " mu of the table, " + std::to_string(kApproximationSamples) + " shared samples each");
  }
  if (comparisons.empty()) {
    plan.push_back("approximations: none to measure (the model uses no approximation with an exact counterpart "
                   "in the library)");
  }

  // --- MERL. ---
  std::string merl_bytes;
  if (input.merl) {
    MerlOptions mo;
    mo.phi_h_samples = merl_azimuths;
    const double row_units = merl_units / kMerlThetaH;
    mo.row_done = [&] {
      progress.check_cancel();
      progress.step("merl", row_units, 0);
    };
    progress.check_cancel();
    merl_bytes = encode_merl(*bxdf, mo);
    std::string note = "merl: 90 x 90 x 180 table sampled at cell centres (MERL reader convention, see merl.h)";
    if (merl_anisotropic) {
      note += "; anisotropic model averaged over " + std::to_string(merl_azimuths) +
              " azimuths of the half vector (MERL is isotropic)";
    }
    if (!bxdf->reciprocal()) note += "; model not reciprocal: the table holds (f(o,i) + f(i,o)) / 2";
    plan.push_back(note);
  } else {
    plan.push_back("merl skipped: not requested");
  }

  // --- Encoding. ---
  progress.check_cancel();
  const std::string settings = "table_mu=" + std::to_string(n_mu) + " table_roughness=" + std::to_string(n_r) +
                               " samples=" + std::to_string(input.samples) +
                               " target_error=" + shortest_number(input.target_error) +
                               " seed=" + std::to_string(input.seed);
  {
    image::FloatImage img;
    img.width = n_mu;
    img.height = 1;
    img.channels = 8;
    img.channel_names = {"R", "G", "B", "err.R", "err.G", "err.B", "white", "white_err"};
    img.pixels.resize(static_cast<size_t>(n_mu) * 8);
    for (int i = 0; i < n_mu; ++i) {
      const Estimate& a = result.albedo.e[i];
      const Estimate& w = result.white_furnace.e[i];
      const double px[8] = {a.value.r,     a.value.g,     a.value.b,         a.std_error.r,
                            a.std_error.g, a.std_error.b, w.value.average(), w.std_error.max()};
      for (int c = 0; c < 8; ++c) img.at(i, 0, c) = static_cast<float>(px[c]);
    }
    img.metadata["kiln:table"] = "directional albedo E(mu) = integral of f cos(theta_i) over the hemisphere";
    img.metadata["kiln:x_axis"] = "mu = cos(theta_o) = (x + 0.5) / " + std::to_string(n_mu);
    img.metadata["kiln:channels"] =
        "R,G,B: E(mu) as configured; err.*: standard errors; white: E(mu) with F = 1, white; white_err";
    img.metadata["kiln:model"] = result.description;
    img.metadata["kiln:average_albedo"] = rgb_list(result.average_albedo);
    img.metadata["kiln:settings"] = settings;
    result.outputs.push_back({"albedo.exr", "image/x-exr", "scene_linear", image::encode_exr(img)});
  }
  {
    image::FloatImage img;
    img.width = n_mu;
    img.height = n_r;
    img.channels = 4;
    img.channel_names = {"scale", "bias", "scale_err", "bias_err"};
    img.pixels.resize(cells * 4);
    const brdf::SplitSumTable& t = result.split_sum;
    for (int j = 0; j < n_r; ++j) {
      for (int i = 0; i < n_mu; ++i) {
        const size_t idx = static_cast<size_t>(j) * n_mu + i;
        img.at(i, j, 0) = static_cast<float>(t.scale[idx]);
        img.at(i, j, 1) = static_cast<float>(t.bias[idx]);
        img.at(i, j, 2) = static_cast<float>(t.scale_error[idx]);
        img.at(i, j, 3) = static_cast<float>(t.bias_error[idx]);
      }
    }
    img.metadata["kiln:table"] = "split sum: E ~= f0 * scale + bias, white model without Fresnel";
    img.metadata["kiln:x_axis"] = "mu = cos(theta_o) = (x + 0.5) / " + std::to_string(n_mu);
    img.metadata["kiln:y_axis"] = std::string(brdf::roughness_name(spec.model)) + " = (y + 0.5) / " +
                                  std::to_string(n_r) + " * " + shortest_number(brdf::max_roughness(spec.model)) +
                                  (rough_axis ? "" : " (no roughness parameter: every row is the same)");
    img.metadata["kiln:model"] = "white, Fresnel-free form of " + result.description;
    img.metadata["kiln:settings"] = settings;
    result.outputs.push_back({"split_sum.exr", "image/x-exr", "data", image::encode_exr(img)});
  }
  if (input.merl) {
    result.outputs.push_back({"brdf.merl", "application/x-merl-brdf", "scene_linear", std::move(merl_bytes)});
  }
  result.seconds = elapsed();

  result.outputs.push_back(material_report(input, result, entries.size()));
  progress.finish();
  return result;
}

}  // namespace kiln::material
