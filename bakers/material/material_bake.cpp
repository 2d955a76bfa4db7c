#include "bakers/material/material_bake.h"
#include "proto/bounds.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <utility>

#include "bakers/image/color.h"
#include "bakers/material/approximations.h"
#include "bakers/material/material_report.h"
#include "bakers/material/material_preview.h"
#include "bakers/material/merl.h"
#include "bakers/material/model_traits.h"
#include "bakers/material/model_validation.h"
#include "bakers/material/number_text.h"
#include "bakers/material/progress_tracker.h"
#include "bakers/material/table_entry.h"
#include "bakers/material/table_images.h"

namespace kiln::material {
namespace {

using Clock = ProgressTracker::Clock;
using brdf::Estimate;

constexpr int kMaxTable = bounds::kTableSize.hi;  // the library also accepts one-entry tables
constexpr uint64_t kMaxSamples = uint64_t{1} << 30;
constexpr uint64_t kDefaultSamples = 4096;
constexpr uint64_t kDefaultCap = uint64_t{1} << 20;  // per entry when only target_error is given
constexpr uint64_t kFirstRound = 1024;               // first pass of a progressive bake
// Odd: anisotropic lobes are usually unchanged by turning the whole configuration by π, which would pair up an
// even count of evenly spaced azimuths; 7 of them act like 14 over [0, π).
constexpr int kMerlAnisotropicAzimuths = 7;

// One bake as its stages fill it in.
struct MaterialBakeRun {
  MaterialBakeRun(const MaterialBakeInput& in, const bake::BakeControl& control)
      : input(in), start(Clock::now()), progress(control, start), n_mu(in.table_mu), n_r(in.table_roughness) {}

  double elapsed() const { return std::chrono::duration<double>(Clock::now() - start).count(); }
  bool out_of_time() const { return input.time_limit_seconds > 0 && elapsed() >= input.time_limit_seconds; }

  const MaterialBakeInput& input;
  const Clock::time_point start;
  ProgressTracker progress;
  const int n_mu, n_r;

  TableModels models;
  bool rough_axis = false;        // the model has a roughness parameter (else every split-sum row is the same)
  std::vector<double> roughness;  // of each split-sum row

  // Fixed mode: `goal` samples per entry. Target mode: refine each entry up to the cap `goal`.
  bool target_mode = false, progressive = false;
  uint64_t goal = 0, first_round = 0;
  std::vector<Entry> entries;
  int passes = 0;
  bool time_up = false;
  int above_target = 0;

  std::vector<Comparison> comparisons;
  int merl_azimuths = 1;
  double merl_units = 0;
  std::string merl_bytes;

  MaterialBakeResult result;
};

void check_finite(const Estimate& e, const std::string& what) {
  if (!e.value.is_finite() || !e.std_error.is_finite()) {
    throw std::runtime_error("material bake: the estimate of " + what +
                             " is not finite; this is a bug in the model, please report it with the model "
                             "parameters");
  }
}

// --- Models and plan. ---------------------------------------------------------------------------------------------

// The model as configured, its white-furnace form, and the white form at each roughness texel centre of the split-sum
// rows (a model without a roughness parameter has one distinct row). A two-lobe material's rows are its specular
// lobe's.
void make_models(MaterialBakeRun& run) {
  const MaterialBakeInput& input = run.input;
  if (input.material) {
    run.models.bxdf = std::make_unique<brdf::Material>(*input.material);
    run.models.white = std::make_unique<brdf::Material>(brdf::without_fresnel(*input.material));
  } else {
    run.models.bxdf = brdf::make_bxdf(input.model);
    run.models.white = brdf::make_bxdf(brdf::without_fresnel(input.model));
  }
  run.result.description = run.models.bxdf->describe();
  const brdf::ModelSpec& rows_spec = split_sum_lobe(input);
  const brdf::ModelSpec white_rows = brdf::without_fresnel(rows_spec);
  run.rough_axis = has_roughness(rows_spec.model);
  const int distinct_rows = run.rough_axis ? run.n_r : 1;
  run.roughness.resize(run.n_r);
  for (int j = 0; j < run.n_r; ++j) run.roughness[j] = (j + 0.5) / run.n_r * brdf::max_roughness(rows_spec.model);
  for (int j = 0; j < distinct_rows; ++j) {
    run.models.rows.push_back(brdf::make_bxdf(brdf::with_roughness(white_rows, run.roughness[j])));
  }
}

void plan_tables(MaterialBakeRun& run) {
  const MaterialBakeInput& input = run.input;
  const brdf::Model model = split_sum_lobe(input).model;
  run.target_mode = input.target_error > 0;
  run.progressive = run.target_mode || input.time_limit_seconds > 0;
  run.goal = input.samples ? input.samples : (run.target_mode ? kDefaultCap : kDefaultSamples);
  run.first_round = run.progressive ? std::min(run.goal, kFirstRound) : run.goal;

  std::vector<std::string>& plan = run.result.plan;
  const std::string n_mu = std::to_string(run.n_mu), n_r = std::to_string(run.n_r);
  plan.push_back("model: " + run.result.description);
  plan.push_back("albedo table: E(mu) at " + n_mu + " texel centres mu = (i + 0.5) / " + n_mu +
                 ", model as configured, averaged over the azimuth of wo");
  plan.push_back("white-furnace table: E(mu) of " + run.models.white->describe() +
                 " (F = 1, white), for the strict energy check and energy compensation");
  const std::string of_lobe = input.material ? " of the specular lobe" : "";
  if (run.rough_axis) {
    plan.push_back("split-sum table" + of_lobe + ": " + n_mu + " x " + n_r + " over (mu, " +
                   brdf::roughness_name(model) + " in (0, " + shortest_number(brdf::max_roughness(model)) +
                   "]), white model without Fresnel, E ~= f0 * scale + bias");
  } else {
    plan.push_back("split-sum table" + of_lobe + ": " + n_mu + " x " + n_r + "; " + brdf::to_string(model) +
                   " has no roughness parameter, so one row is computed and repeated");
  }
  plan.push_back(
      "average albedo: E_avg = 2 * integral of E(mu) mu dmu, estimated directly (mu = sqrt(xi)), both forms");
}

// Samples per entry in fixed mode: the first round and the doublings after it, each in blocks.
uint64_t fixed_forecast(const MaterialBakeRun& run) {
  if (!run.progressive) return taken_in_blocks(run.goal);
  uint64_t requested = run.first_round, total = taken_in_blocks(run.first_round);
  while (requested < run.goal) {
    const uint64_t add = std::min(requested, run.goal - requested);
    total += taken_in_blocks(add);
    requested += add;
  }
  return total;
}

// Every table entry, in the order that numbers their seeds, with its forecast of samples: exact for a fixed count;
// the first round, to be revised, for a target.
void make_entries(MaterialBakeRun& run) {
  const auto add = [&](Kind kind, int i_mu, int i_roughness) {
    Entry e;
    e.kind = kind;
    e.i_mu = i_mu;
    e.i_roughness = i_roughness;
    run.entries.push_back(e);
  };
  for (int i = 0; i < run.n_mu; ++i) add(Kind::albedo, i, 0);
  for (int i = 0; i < run.n_mu; ++i) add(Kind::white, i, 0);
  add(Kind::average, 0, 0);
  add(Kind::white_average, 0, 0);
  const int distinct_rows = run.rough_axis ? run.n_r : 1;
  for (int j = 0; j < distinct_rows; ++j)
    for (int i = 0; i < run.n_mu; ++i) add(Kind::split_sum, i, j);
  const uint64_t planned = run.target_mode ? taken_in_blocks(run.first_round) : fixed_forecast(run);
  for (Entry& e : run.entries) e.planned = static_cast<double>(planned);
}

// The planned work of every stage, in samples or BRDF evaluations (they cost about the same).
void plan_work(MaterialBakeRun& run) {
  run.comparisons = run.input.material ? approximations(*run.input.material, run.result.plan)
                                       : approximations(run.input.model, run.result.plan);
  run.merl_azimuths = anisotropic(run.input) ? kMerlAnisotropicAzimuths : 1;
  run.merl_units = run.input.merl
                       ? static_cast<double>(kMerlEntries) * run.merl_azimuths * (run.models.bxdf->reciprocal() ? 1 : 2)
                       : 0.0;
  double validation_units = 2.0 * kReciprocityPairs;
  for (const Comparison& c : run.comparisons) {
    validation_units +=
        static_cast<double>(1 + c.exact.size()) * run.n_mu * static_cast<double>(taken(kApproximationSamples));
  }
  double table_units = 0;
  for (const Entry& e : run.entries) table_units += e.planned;
  run.progress.add_planned(table_units + validation_units + run.merl_units);
}

// --- Passes over the entries. -------------------------------------------------------------------------------------

// Forecast of an entry's total: variance falls as 1/N, so N (se / target)² samples reach the target.
void update_forecast(const MaterialBakeRun& run, Entry& e, double err) {
  if (e.done) {
    e.planned = static_cast<double>(e.samples);
  } else if (run.target_mode) {
    const double ratio = err / run.input.target_error;
    e.planned = std::min(std::max(static_cast<double>(e.samples) * ratio * ratio, 2.0 * e.samples),
                         static_cast<double>(std::max(run.goal, e.samples)));
  }
}

// Entry k's share of a pass: pass 0 takes the first round; later passes double its samples, within the goal or cap,
// unless the time limit passes first.
void refine_entry(MaterialBakeRun& run, size_t k, int pass, uint64_t& block_counter) {
  const MaterialBakeInput& input = run.input;
  Entry& e = run.entries[k];
  uint64_t want = pass == 0 ? run.first_round : std::min(e.requested, run.goal - e.requested);
  while (want > 0) {
    run.progress.check_cancel();
    if (pass > 0 && run.out_of_time()) break;
    const uint64_t block = std::min(want, kMaxBlock);
    const double old_error = e.samples ? e.error() : -1.0;
    const double old_planned = e.planned;
    const Estimate est = estimate_block(run.models, e, run.n_mu, block, block_seed(input.seed, k, block_counter++));
    e.add(est);
    e.requested += block;
    want -= block;
    const double err = e.error();
    if (want == 0) e.done = (run.target_mode && err <= input.target_error) || e.requested >= run.goal;
    update_forecast(run, e, err);
    run.progress.step("tables", static_cast<double>(est.samples), static_cast<uint64_t>(est.samples),
                      e.planned - old_planned, old_error, err);
  }
}

// Passes over the unfinished entries until each is done or the time limit has passed (the first pass always
// completes, so every entry has a value).
void run_passes(MaterialBakeRun& run) {
  std::vector<uint64_t> block_counter(run.entries.size(), 0);
  for (int pass = 0;; ++pass) {
    std::vector<size_t> active;
    for (size_t k = 0; k < run.entries.size(); ++k)
      if (!run.entries[k].done) active.push_back(k);
    if (active.empty()) break;
    if (pass > 0 && run.out_of_time()) {
      run.time_up = true;
      break;
    }
    ++run.passes;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, active.size(), 1), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t a = r.begin(); a != r.end(); ++a) refine_entry(run, active[a], pass, block_counter[active[a]]);
    });
    if (!run.progressive) break;  // fixed samples without a time limit: one pass takes them all
  }
}

// --- Tables from the entries. -------------------------------------------------------------------------------------

void summarise_entries(MaterialBakeRun& run) {
  MaterialBakeResult& result = run.result;
  uint64_t table_samples = 0;
  result.min_samples_per_entry = UINT64_MAX;
  for (const Entry& e : run.entries) {
    table_samples += e.samples;
    result.min_samples_per_entry = std::min(result.min_samples_per_entry, e.samples);
    result.max_samples_per_entry = std::max(result.max_samples_per_entry, e.samples);
    result.max_error_estimate = std::max(result.max_error_estimate, e.error());
    if (run.target_mode && e.error() > run.input.target_error) ++run.above_target;
  }
  result.samples = table_samples;
  result.target_reached = !run.target_mode || run.above_target == 0;
}

void store_entry(MaterialBakeRun& run, const Entry& e) {
  MaterialBakeResult& result = run.result;
  const Estimate est = e.estimate();
  switch (e.kind) {
    case Kind::albedo:
      check_finite(est, "the directional albedo at mu = " + shortest_number(mu_at(e.i_mu, run.n_mu)));
      result.albedo.e.push_back(est);
      break;
    case Kind::white:
      check_finite(est, "the white-furnace albedo at mu = " + shortest_number(mu_at(e.i_mu, run.n_mu)));
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
      check_finite(est, "the split-sum entry at mu = " + shortest_number(mu_at(e.i_mu, run.n_mu)));
      // Rows of a model without roughness are all the same row.
      for (int j = run.rough_axis ? e.i_roughness : 0; j < (run.rough_axis ? e.i_roughness + 1 : run.n_r); ++j) {
        const size_t idx = static_cast<size_t>(j) * run.n_mu + e.i_mu;
        result.split_sum.scale[idx] = est.value.r;
        result.split_sum.bias[idx] = est.value.g;
        result.split_sum.scale_error[idx] = est.std_error.r;
        result.split_sum.bias_error[idx] = est.std_error.g;
      }
      break;
  }
}

void fill_tables(MaterialBakeRun& run) {
  MaterialBakeResult& result = run.result;
  for (brdf::AlbedoTable* t : {&result.albedo, &result.white_furnace}) {
    for (int i = 0; i < run.n_mu; ++i) t->mu.push_back(mu_at(i, run.n_mu));
  }
  brdf::SplitSumTable& split_sum = result.split_sum;
  split_sum.n_mu = run.n_mu;
  split_sum.n_roughness = run.n_r;
  for (int i = 0; i < run.n_mu; ++i) split_sum.mu.push_back(mu_at(i, run.n_mu));
  split_sum.roughness = run.roughness;
  const size_t cells = static_cast<size_t>(run.n_mu) * run.n_r;
  split_sum.scale.assign(cells, 0.0);
  split_sum.bias.assign(cells, 0.0);
  split_sum.scale_error.assign(cells, 0.0);
  split_sum.bias_error.assign(cells, 0.0);
  for (const Entry& e : run.entries) store_entry(run, e);
  result.average_albedo = result.albedo.average.value;
}

void plan_sampling(MaterialBakeRun& run) {
  const MaterialBakeInput& input = run.input;
  MaterialBakeResult& result = run.result;
  std::vector<std::string>& plan = result.plan;
  const std::string per_entry =
      std::to_string(result.min_samples_per_entry) + (result.min_samples_per_entry == result.max_samples_per_entry
                                                          ? ""
                                                          : ".." + std::to_string(result.max_samples_per_entry));
  const std::string n_entries = std::to_string(run.entries.size());
  if (!run.target_mode) {
    plan.push_back("sampling: " + std::string(input.samples ? "" : "default ") + std::to_string(run.goal) +
                   " samples per entry requested, " + per_entry + " taken (whole stratified replicates) for " +
                   n_entries + " entries");
  } else if (result.target_reached) {
    plan.push_back("sampling: target_error " + shortest_number(input.target_error) + " reached for all " + n_entries +
                   " entries after " + per_entry + " samples per entry (" + std::to_string(run.passes) + " passes)");
  } else {
    plan.push_back(
        "sampling: target_error " + shortest_number(input.target_error) + " not reached for " +
        std::to_string(run.above_target) + " of " + n_entries + " entries (largest error " +
        shortest_number(result.max_error_estimate) + ") after " + per_entry + " samples per entry: " +
        (run.time_up ? "time limit reached" : "cap of " + std::to_string(run.goal) + " samples per entry reached"));
  }
  if (input.time_limit_seconds > 0) {
    plan.push_back(
        "time limit " + shortest_number(input.time_limit_seconds) + " s: " +
        (run.time_up ? "reached, refinement stopped after " + std::to_string(run.passes) + " passes" : "not reached"));
  }
}

// --- Validation, MERL, outputs. -------------------------------------------------------------------------------------

void validate_model(MaterialBakeRun& run) {
  MaterialBakeResult& result = run.result;
  ValidationReport& v = result.validation;
  const brdf::Bxdf& bxdf = *run.models.bxdf;
  v.energy = check_energy(result.albedo, result.white_furnace);
  v.reciprocity = check_reciprocity(bxdf, run.input.seed);
  run.progress.step("validation", 2.0 * kReciprocityPairs, 0);
  result.plan.push_back("reciprocity: " + std::to_string(kReciprocityPairs) +
                        " random direction pairs, uniform over the hemisphere");
  for (const Comparison& cmp : run.comparisons) {
    // A material's approximations are its lobes': each is measured on the lobe alone.
    const std::unique_ptr<brdf::Bxdf> lobe = cmp.lobe ? brdf::make_bxdf(*cmp.lobe) : nullptr;
    v.approximations.push_back(measure_approximation(lobe ? *lobe : bxdf, cmp, run.n_mu, run.input.seed, run.progress,
                                                     &result.validation_samples));
    result.plan.push_back("approximation " + cmp.name + ": albedo difference measured at the " +
                          std::to_string(run.n_mu) + " mu of the table, " + std::to_string(kApproximationSamples) +
                          " shared samples each");
  }
  if (run.comparisons.empty()) {
    result.plan.push_back(
        "approximations: none to measure (the model uses no approximation with an exact counterpart "
        "in the library)");
  }
}

void tabulate_merl_table(MaterialBakeRun& run) {
  if (!run.input.merl) {
    run.result.plan.push_back("merl skipped: not requested");
    return;
  }
  MerlOptions mo;
  mo.phi_h_samples = run.merl_azimuths;
  const double row_units = run.merl_units / kMerlThetaH;
  mo.row_done = [&] {
    run.progress.check_cancel();
    run.progress.step("merl", row_units, 0);
  };
  run.progress.check_cancel();
  const brdf::Bxdf& bxdf = *run.models.bxdf;
  run.merl_bytes = encode_merl(bxdf, mo);
  std::string note = "merl: 90 x 90 x 180 table sampled at cell centres (MERL reader convention, see merl.h)";
  if (run.merl_azimuths > 1) {
    note += "; anisotropic model averaged over " + std::to_string(run.merl_azimuths) +
            " azimuths of the half vector (MERL is isotropic)";
  }
  if (!bxdf.reciprocal()) note += "; model not reciprocal: the table holds (f(o,i) + f(i,o)) / 2";
  run.result.plan.push_back(note);
}

void encode_outputs(MaterialBakeRun& run) {
  run.progress.check_cancel();
  MaterialBakeResult& result = run.result;
  const std::string settings = table_settings(run.input);
  result.outputs.push_back(albedo_image(result, settings));
  result.outputs.push_back(split_sum_image(result, split_sum_lobe(run.input).model, run.rough_axis, settings));
  if (run.input.merl) {
    result.outputs.push_back({"brdf.merl", "application/x-merl-brdf", "scene_linear", std::move(run.merl_bytes)});
  }
  if (run.input.preview) {
    PreviewOptions options;
    options.seed = static_cast<uint32_t>(run.input.seed);
    const PreviewImage image =
        render_preview(*run.models.bxdf, *run.models.white, options, run.progress.cancel_flag());
    result.outputs.push_back(preview_output(image, image::ColorConfig::active().working_space()));
    result.plan.push_back("preview.png: the material under a studio environment and a sun, and its white-furnace "
                          "form, " + std::to_string(options.samples_per_pixel) + " samples per pixel");
  }
  result.seconds = run.elapsed();
}

}  // namespace

std::optional<bake::InvalidInput> validate(const MaterialBakeInput& in) {
  using bake::InvalidInput;
  if (in.material) {
    if (auto e = brdf::validate(*in.material)) return e->under("material");
  } else if (auto e = brdf::validate(in.model)) {
    return e->under("model");
  }
  if (in.table_mu < 1 || in.table_mu > kMaxTable) {
    return InvalidInput("table_mu",
                        "must be in [1, " + std::to_string(kMaxTable) + "], got " + std::to_string(in.table_mu));
  }
  if (in.table_roughness < 1 || in.table_roughness > kMaxTable) {
    return InvalidInput("table_roughness",
                        "must be in [1, " + std::to_string(kMaxTable) + "], got " + std::to_string(in.table_roughness));
  }
  if (in.samples > kMaxSamples) {
    return InvalidInput("samples", "must be at most " + std::to_string(kMaxSamples) + " per table entry, got " +
                                       std::to_string(in.samples));
  }
  if (!std::isfinite(in.target_error) || in.target_error < 0) {
    return InvalidInput("target_error",
                        "must be a finite number >= 0 (0: off), got " + shortest_number(in.target_error));
  }
  if (!std::isfinite(in.time_limit_seconds) || in.time_limit_seconds < 0) {
    return InvalidInput("time_limit_seconds",
                        "must be a finite number >= 0 (0: none), got " + shortest_number(in.time_limit_seconds));
  }
  return std::nullopt;
}

uint64_t estimate_material_memory(const MaterialBakeInput& in) {
  constexpr double kBytesPerEntry = 16 * sizeof(double);  // sums, square sums and counts per RGB entry, and the file
  const double entries = static_cast<double>(in.table_mu) * (1.0 + static_cast<double>(in.table_roughness));
  const double merl = in.merl ? 2.0 * 90 * 90 * 180 * 3 * sizeof(double) : 0.0;
  return static_cast<uint64_t>(entries * kBytesPerEntry + merl) + (uint64_t{16} << 20);
}

MaterialBakeResult bake_material(const MaterialBakeInput& input, const bake::BakeControl& control) {
  if (auto error = validate(input)) throw *error;
  MaterialBakeRun run(input, control);
  run.progress.check_cancel();
  make_models(run);
  plan_tables(run);
  make_entries(run);
  plan_work(run);
  run_passes(run);
  summarise_entries(run);
  fill_tables(run);
  plan_sampling(run);
  validate_model(run);
  tabulate_merl_table(run);
  encode_outputs(run);
  run.result.outputs.push_back(material_report(input, run.result, run.entries.size()));
  run.progress.finish();
  return std::move(run.result);
}

}  // namespace kiln::material
