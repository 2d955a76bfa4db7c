// The material bake's checks of the model itself: energy conservation read off the tables, reciprocity at random
// direction pairs, and the albedo each approximation costs against its exact form.
#pragma once

#include <cstdint>

#include "bakers/brdf/albedo.h"
#include "bakers/brdf/bxdf.h"
#include "bakers/material/approximations.h"
#include "bakers/material/material_bake.h"
#include "bakers/material/progress_tracker.h"

namespace kiln::material {

constexpr int kReciprocityPairs = 4096;
constexpr int kApproximationSamples = 8192;  // per μ; both sides share their samples, so differences are precise

// The largest albedo of each form over μ and channels, and whether either exceeds 1 beyond its noise.
EnergyCheck check_energy(const brdf::AlbedoTable& albedo, const brdf::AlbedoTable& white_furnace);

// f(o, i) against f(i, o) at kReciprocityPairs pairs uniform over the hemisphere, drawn from the bake's seed.
ReciprocityCheck check_reciprocity(const brdf::Bxdf& bxdf, uint64_t seed);

// The albedo difference between bxdf and the exact form of cmp at the table's n_mu texel centres, with shared seeds.
// Adds the samples it took to *samples.
ApproximationError measure_approximation(const brdf::Bxdf& bxdf, const Comparison& cmp, int n_mu, uint64_t seed,
                                         ProgressTracker& progress, uint64_t* samples);

}  // namespace kiln::material
