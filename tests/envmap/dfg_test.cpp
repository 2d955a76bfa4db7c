// The split-sum DFG table of the environment bake.
#include "bakers/envmap/dfg.h"

#include <gtest/gtest.h>

#include <cmath>

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
