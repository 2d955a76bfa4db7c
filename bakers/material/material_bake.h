// The material bake: one BRDF model, or a two-lobe material (brdf::MaterialSpec), in; its tables (EXR), a tabulated
// BRDF (MERL), a validation report and a JSON report out. Plain C++ types only: the daemon translates its messages into
// MaterialBakeInput and back.
//
// What it computes (μ = cos θ_o at texel centres (i + 0.5) / table_mu, azimuth of wo averaged):
//   albedo       E(μ) = ∫ f(wo, wi) cos θ_i dω_i of the model as configured (colours, Fresnel);
//   white        E(μ) of the white-furnace form: the same shape, white, Fresnel off (F = 1); what an
//                energy-compensation term needs, and the strict energy test (it must not exceed 1);
//   split sum    scale and bias over (μ, roughness) with E ≈ f0 · scale + bias (see brdf::split_sum_table);
//   averages     E_avg = 2 ∫ E(μ) μ dμ of both forms, estimated directly (μ = √ξ), not from the table.
// Every entry is an unbiased Monte Carlo estimate with its standard error (from independent replicates).
//
// Sampling: each entry is estimated in rounds with independent seeds; rounds are combined by their sample
// counts (mean = Σ n_k m_k / N, variance = Σ (n_k / N)² se_k²), which stays unbiased where an inverse-variance
// weighting would correlate the weights with the noise. Passes over all entries double each unfinished entry's
// samples until its standard error is at most target_error, or it reaches the sample cap, or the time limit has
// passed (the first pass always completes, so every entry has a value).
//
// Threads: tbb::parallel_for over entries (and over MERL rows), inside whatever TBB arena the caller runs in; the
// caller limits the thread count with a tbb::task_arena or tbb::global_control.
//
// Outputs (bake::BakeOutput.name):
//   albedo.exr     width table_mu, height 1, 8 float channels: R, G, B = E(μ); err.R, err.G, err.B = their standard
//                  errors; white = E(μ) of the white-furnace form; white_err. Pixel x ↔ μ = (x + 0.5) / table_mu.
//   split_sum.exr  width table_mu, height table_roughness, channels scale, bias, scale_err, bias_err. Pixel (x, y) ↔
//                  μ = (x + 0.5) / table_mu, roughness = (y + 0.5) / table_roughness · max_roughness (row 0, the top
//                  row, is the smoothest); roughness is the model's own parameter (brdf::roughness_name).
//   brdf.merl      when merl is set: the MERL binary layout (see merl.h), 34 992 012 bytes.
//   preview.png    unless preview is off: spheres of the material under a studio environment and a sun, and of its
//                  white-furnace form (material_preview.h), 480 × 160, through OpenColorIO's display transform.
//   report.json    everything in MaterialBakeResult but the tables, for people and pipelines.
// Both EXRs carry their layout, the model and the bake settings in string attributes (kiln:*).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "bakers/bake/cancelled.h"
#include "bakers/bake/control.h"
#include "bakers/bake/invalid_input.h"
#include "bakers/bake/output.h"
#include "bakers/brdf/albedo.h"
#include "bakers/brdf/material.h"
#include "bakers/brdf/model_spec.h"
#include "bakers/math/rgb.h"
#include "bakers/math/vec3.h"

namespace kiln::material {

// --- The material bake. ----------------------------------------------------------------------------------------

// Changes whenever the same input would give different outputs (part of the daemon's result-cache key).
inline constexpr const char* kMaterialBakerVersion = "kiln-material-4";

struct MaterialBakeInput {
  brdf::ModelSpec model;
  // A two-lobe material (the layered or weighted model lightmaps shade with); when set, it is what is baked and
  // `model` is ignored. Its split-sum table is that of its specular lobe (white, Fresnel off) over the specular
  // lobe's roughness: the lobe an engine lights with the prefiltered environment. Its approximations are measured
  // lobe by lobe; everything else (albedo, white furnace, validation, MERL, preview) is of the whole material.
  std::optional<brdf::MaterialSpec> material;
  int table_mu = 32;         // [1, 1024] texels along μ
  int table_roughness = 32;  // [1, 1024] rows of the split-sum table
  bool merl = false;         // also tabulate the BRDF in the MERL layout
  bool preview = true;       // preview.png (material_preview.h)
  // Samples per table entry. 0: 4096, or as many as target_error needs (up to 1 048 576). With target_error set,
  // this is the cap. At most 2^30. Counts are rounded up to whole stratified replicates.
  uint64_t samples = 0;
  double target_error = 0;  // stop refining an entry once its standard error is at most this; 0: off
  // Stop refining the tables after this long (their first pass still completes; validation and MERL follow);
  // 0: none.
  double time_limit_seconds = 0;
  uint64_t seed = 1;  // the same input and seed give the same tables
};

struct EnergyCheck {
  // Largest directional albedo over μ and channels with F as configured, with where it is and its standard error.
  double max_albedo = 0, max_albedo_mu = 0, max_albedo_error = 0;
  int max_albedo_channel = 0;  // 0 R, 1 G, 2 B
  // The same for the white-furnace form (F = 1, white): the strict test.
  double white_max_albedo = 0, white_max_albedo_mu = 0, white_max_albedo_error = 0;
  // Neither maximum exceeds 1 by more than 3 standard errors (+1e-9 for rounding).
  bool conserves_energy = true;
};

struct ReciprocityCheck {
  int pairs = 0;                       // random direction pairs, uniform over the hemisphere
  double max_relative_difference = 0;  // max over pairs and channels of |f(o,i) − f(i,o)| / max(f(o,i), f(i,o))
  Vec3 worst_wo, worst_wi;
  bool model_claims_reciprocal = true;  // Bxdf::reciprocal()
};

// The cost of one approximation the model uses: its albedo against the exact form's, same samples.
struct ApproximationError {
  std::string name;               // e.g. "fresnel: schlick vs exact (eta from f0)"
  double max_abs_difference = 0;  // max over μ and channels of |E_approx(μ) − E_exact(μ)|
  double at_mu = 0;
  double mean_abs_difference = 0;  // over μ and channels
  double std_error = 0;            // of the difference at at_mu, if both estimates were independent (an upper bound)
};

struct ValidationReport {
  EnergyCheck energy;
  ReciprocityCheck reciprocity;
  std::vector<ApproximationError> approximations;  // empty when the model uses no approximation we can compare
};

struct MaterialBakeResult {
  std::vector<bake::BakeOutput> outputs;  // in the order listed above; report.json last
  std::string description;                // Bxdf::describe() of the model

  brdf::AlbedoTable albedo;         // E(μ) as configured, and average (E_avg with its error)
  brdf::AlbedoTable white_furnace;  // E(μ) and E_avg with F = 1, white
  brdf::SplitSumTable split_sum;
  Rgb average_albedo;  // = albedo.average.value
  ValidationReport validation;

  uint64_t samples = 0;             // all Monte Carlo samples of the tables (validation samples not included)
  uint64_t validation_samples = 0;  // samples of the approximation comparisons
  double seconds = 0;
  double max_error_estimate = 0;  // largest standard error of any table entry or average
  uint64_t min_samples_per_entry = 0, max_samples_per_entry = 0;
  bool target_reached = true;     // every entry at or below target_error (true when no target was set)
  std::vector<std::string> plan;  // what was computed and why, for people
};

// Throws bake::InvalidInput naming the field ("table_mu": "must be in [1, 1024], got 0", "model.alpha_x": "must be in
// (0, 1], got -0.2"); bake::BakeCancelled when cancelled; std::runtime_error otherwise.
MaterialBakeResult bake_material(const MaterialBakeInput& input, const bake::BakeControl& control = {});

// nullopt if the input is valid, else the first offending field and what is wrong with it.
std::optional<bake::InvalidInput> validate(const MaterialBakeInput& input);

// The peak memory of a bake of `input`, for a daemon's admission: the tables (table_mu × table_roughness entries of
// a few RGB sums each, and their EXR files), the MERL table when asked (90 × 90 × 180 RGB doubles, and its file),
// and 16 MiB for the validation, the report and the code's own working set.
uint64_t estimate_material_memory(const MaterialBakeInput& input);

}  // namespace kiln::material
