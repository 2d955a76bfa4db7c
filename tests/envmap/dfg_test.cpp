// The split-sum DFG table of the environment bake.
#include "bakers/envmap/dfg.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "bakers/envmap/lobe.h"
#include "bakers/material/material_bake.h"

namespace kiln::envmap {
namespace {

brdf::ModelSpec ggx() {
  brdf::ModelSpec s;
  s.model = brdf::Model::ggx;
  return s;
}

TEST(Dfg, RoughnessMappingIsAlphaEqualsRhoSquared) {
  EXPECT_DOUBLE_EQ(lobe_at_roughness(ggx(), 0.5).alpha_x, 0.25);
  brdf::ModelSpec s;
  s.model = brdf::Model::schlick;
  // Schlick's Z(t) is GGX with α² = r: r = ρ⁴ makes α = ρ² as for the microfacet lobes.
  EXPECT_DOUBLE_EQ(lobe_at_roughness(s, 0.5).layer.r, 0.0625);
}

TEST(Dfg, MaskingIsHeightCorrelatedByDefaultForTheSmithLobes) {
  for (EnvLobe l : {EnvLobe::ggx, EnvLobe::beckmann, EnvLobe::schlick}) {
    EXPECT_EQ(dfg_masking(l), brdf::Masking::height_correlated) << to_string(l);
    EXPECT_EQ(lobe_model(l).masking, brdf::Masking::height_correlated) << to_string(l);
    EXPECT_EQ(dfg_masking(l, brdf::Masking::separable), brdf::Masking::separable) << to_string(l);
    EXPECT_FALSE(dfg_masking_problem(l, brdf::Masking::separable));
    EXPECT_TRUE(dfg_masking_problem(l, brdf::Masking::v_groove));
  }
  EXPECT_EQ(dfg_masking(EnvLobe::cook_torrance), brdf::Masking::v_groove);
  EXPECT_TRUE(dfg_masking_problem(EnvLobe::cook_torrance, brdf::Masking::height_correlated));
}

// The environment's DFG table (GGX, its default height-correlated masking) against the split-sum table of a material
// bake of GGX with masking height-correlated: the same integrals by two code paths (the DFG's per-entry seeds and
// ρ axis against the material bake's rounds and α axis). The axes meet where ρ² = α: ρ = (j + 0.5)/2 gives
// α = 0.0625 and 0.5625, the material's rows 0 and 4 of 8, at the same μ = (i + 0.5)/4. Tolerance 1e-4 absolute,
// as the issue asks. The material bake estimates in blocks of a few thousand samples (less stratification than one
// 2^20-sample estimate), so both take 2^20 samples per entry. Measured: largest difference 7.0e-5, largest standard
// error 4.7e-5 (printed). The seeds are fixed, so the outcome is deterministic; a masking mix-up (separable differs
// by up to 0.15) or a roughness-axis mix-up fails by orders of magnitude.
TEST(Dfg, GgxHeightCorrelatedMatchesTheMaterialBakesSplitSum) {
  material::MaterialBakeInput m;
  m.model.model = brdf::Model::ggx;
  m.model.masking = brdf::Masking::height_correlated;
  m.table_mu = 4;
  m.table_roughness = 8;
  m.samples = 1 << 20;
  const material::MaterialBakeResult baked = material::bake_material(m);
  brdf::AlbedoOptions o;
  o.samples = 1 << 20;
  const DfgTable dfg = compute_dfg(lobe_model(EnvLobe::ggx), 4, 2, o);
  double worst = 0.0, worst_error = 0.0;
  for (int j = 0; j < 2; ++j) {
    const int row = 4 * j;  // α = ((j + 0.5)/2)² = (row + 0.5)/8
    ASSERT_NEAR(baked.split_sum.roughness[row], std::pow((j + 0.5) / 2, 2), 1e-15);
    for (int i = 0; i < 4; ++i) {
      const DfgEntry& e = dfg.at(i, j);
      const double ds = std::fabs(e.scale - baked.split_sum.at_scale(row, i));
      const double db = std::fabs(e.bias - baked.split_sum.at_bias(row, i));
      EXPECT_LE(ds, 1e-4) << "scale at mu " << (i + 0.5) / 4 << ", rho " << (j + 0.5) / 2 << ": " << e.scale << " +- "
                          << e.scale_error << " against " << baked.split_sum.at_scale(row, i) << " +- "
                          << baked.split_sum.scale_error[row * 4 + i];
      EXPECT_LE(db, 1e-4) << "bias at mu " << (i + 0.5) / 4 << ", rho " << (j + 0.5) / 2 << ": " << e.bias << " +- "
                          << e.bias_error << " against " << baked.split_sum.at_bias(row, i) << " +- "
                          << baked.split_sum.bias_error[row * 4 + i];
      worst = std::max({worst, ds, db});
      worst_error = std::max({worst_error, e.scale_error, e.bias_error, baked.split_sum.scale_error[row * 4 + i],
                              baked.split_sum.bias_error[row * 4 + i]});
    }
  }
  std::printf("DFG (ggx, height-correlated) vs material split sum: max |difference| %.2e, max standard error %.2e\n",
              worst, worst_error);
}

// A closed form: GGX with α = 1 (ρ = 1) at normal incidence has E = 1 − ln 2 (see tests/brdf/albedo_test.cpp).
TEST(Dfg, EnergyChannelMatchesTheClosedFormAtRoughnessOne) {
  brdf::AlbedoOptions o;
  o.samples = 1 << 18;
  const DfgEntry e = dfg_entry(ggx(), 1.0, 1.0, o);
  // Monte Carlo against an exact value: 5 standard errors.
  EXPECT_NEAR(e.energy, 1.0 - std::log(2.0), 5 * e.energy_error);
  // scale + bias is the energy, sample by sample, so only rounding separates them.
  EXPECT_NEAR(e.scale + e.bias, e.energy, 1e-12);
}

// A smooth lobe at normal incidence reflects almost everything, and Schlick's weight (1 − v·h)^5 is ~0 there:
// scale → 1, bias → 0.
TEST(Dfg, SmoothLobeAtNormalIncidence) {
  const DfgEntry e = dfg_entry(ggx(), 1.0, 0.05);  // α = 0.0025
  EXPECT_NEAR(e.scale, 1.0, 1e-3);  // GGX tail loss at this α is ~α² = 6e-6; the weight is 0 up to 1e-12
  EXPECT_LT(e.bias, 1e-6);
}

TEST(Dfg, TableIsBoundedAndConsistent) {
  brdf::AlbedoOptions o;
  o.samples = 2048;
  const DfgTable t = compute_dfg(ggx(), 8, 8, o);
  ASSERT_EQ(t.entries.size(), 64u);
  for (int j = 0; j < 8; ++j) {
    for (int i = 0; i < 8; ++i) {
      const DfgEntry& e = t.at(i, j);
      EXPECT_GE(e.scale, 0.0);
      EXPECT_GE(e.bias, 0.0);
      // Single-scattering GGX conserves energy: E ≤ 1 within 5 standard errors.
      EXPECT_LE(e.energy, 1.0 + 5 * e.energy_error) << i << "," << j;
      EXPECT_NEAR(e.scale + e.bias, e.energy, 1e-12);
    }
  }
  // Energy lost to single scattering grows with roughness at normal incidence (texel 7 is μ ≈ 0.94).
  EXPECT_GT(t.at(7, 0).energy, t.at(7, 7).energy);
  EXPECT_GT(t.max_error(), 0.0);
}

TEST(Dfg, RejectsBadSizesAndLobes) {
  EXPECT_THROW(compute_dfg(ggx(), 0, 8), std::invalid_argument);
  EXPECT_THROW(compute_dfg(ggx(), 8, 2000), std::invalid_argument);
  brdf::ModelSpec bad = ggx();
  bad.fresnel = brdf::FresnelMode::schlick;
  bad.f0 = Rgb{2.0};
  EXPECT_THROW(compute_dfg(bad, 8, 8), std::invalid_argument);
}

}  // namespace
}  // namespace kiln::envmap
