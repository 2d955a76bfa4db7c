// The material bake of a two-lobe material (brdf::Material, what lightmaps shade with): its albedo against the
// independent bakes of its lobes where the combination is known in closed form, its furnace and reciprocity checks,
// its split-sum table (the specular lobe's), MERL table and report.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <optional>
#include <string>

#include "bakers/brdf/material.h"
#include "bakers/image/exr.h"
#include "bakers/material/material_bake.h"
#include "bakers/material/merl.h"
#include "bakers/math/constants.h"

namespace kiln::material {
namespace {

brdf::ModelSpec ggx(double alpha, const Rgb& f0) {
  brdf::ModelSpec s;
  s.model = brdf::Model::ggx;
  s.alpha_x = s.alpha_y = alpha;
  s.fresnel = brdf::FresnelMode::schlick;
  s.f0 = f0;
  return s;
}

brdf::ModelSpec lambert(const Rgb& albedo) {
  brdf::ModelSpec s;
  s.model = brdf::Model::lambert;
  s.albedo = albedo;
  return s;
}

MaterialBakeResult bake(const MaterialBakeInput& base, uint64_t seed) {
  MaterialBakeInput in = base;
  in.seed = seed;
  in.preview = false;
  return bake_material(in);
}

MaterialBakeInput tables_only(uint64_t samples) {
  MaterialBakeInput in;
  in.table_mu = 8;
  in.table_roughness = 4;
  in.samples = samples;
  return in;
}

// Tables of 8 μ at 16384 samples per entry, without preview: of `material` if given, else of `model`.
MaterialBakeResult bake_tables(const std::optional<brdf::MaterialSpec>& material, const brdf::ModelSpec& model,
                               uint64_t seed) {
  MaterialBakeInput in = tables_only(16384);
  in.material = material;
  in.model = model;
  return bake(in, seed);
}

const bake::BakeOutput* find_output(const MaterialBakeResult& r, const std::string& name) {
  for (const auto& o : r.outputs)
    if (o.name == name) return &o;
  return nullptr;
}

// Tolerance of the comparisons below: the material and its lobes are baked with different seeds, so their estimates
// are independent and unbiased; the difference of the material's E from the closed form of its lobes' is then
// zero-mean with the combined standard error σ. 5σ (each σ estimated from 8 replicates) keeps a deterministic test
// far from a coin flip; 1e-12 absorbs rounding where every σ is 0.
constexpr double kSigmas = 5.0;

// What the closed form of the lobes' bakes predicts for one albedo entry, with the standard error it carries.
struct Expected {
  double value, std_error;
};

// The baked albedo against `expected` at every μ and channel, within kSigmas combined standard errors; records the
// worst difference in σ.
void expect_albedo(const MaterialBakeResult& whole, const std::function<Expected(size_t, int)>& expected) {
  double worst_in_sigmas = 0;
  for (size_t i = 0; i < whole.albedo.e.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      const Expected e = expected(i, c);
      const double sigma = std::hypot(whole.albedo.e[i].std_error[c], e.std_error);
      const double diff = std::fabs(whole.albedo.e[i].value[c] - e.value);
      EXPECT_LE(diff, kSigmas * sigma + 1e-12) << "mu " << whole.albedo.mu[i] << " channel " << c;
      worst_in_sigmas = std::max(worst_in_sigmas, diff / sigma);
    }
  }
  ::testing::Test::RecordProperty("worst_difference_in_sigmas", std::to_string(worst_in_sigmas));
}

TEST(LayeredMaterialBake, WeightedAlbedoIsTheWeightedSumOfItsLobesAlbedos) {
  // Weights: f = (1 − s) f_d + s f_s pointwise, so E(μ) = (1 − s) E_d(μ) + s E_s(μ) exactly, for any lobes.
  brdf::MaterialSpec m;
  m.diffuse.model = brdf::Model::oren_nayar;
  m.diffuse.sigma = 0.4;
  m.diffuse.albedo = Rgb{0.7, 0.5, 0.3};
  m.specular = ggx(0.3, Rgb{0.04});
  m.combine = brdf::Combine::weights;
  m.specular_weight = 0.3;
  const double s = m.specular_weight;
  const MaterialBakeResult whole = bake_tables(m, {}, 1);
  const MaterialBakeResult diffuse = bake_tables({}, m.diffuse, 2);
  const MaterialBakeResult specular = bake_tables({}, m.specular, 3);
  ASSERT_EQ(whole.albedo.e.size(), 8u);
  expect_albedo(whole, [&](size_t i, int c) {
    const brdf::Estimate &d = diffuse.albedo.e[i], &sp = specular.albedo.e[i];
    return Expected{(1 - s) * d.value[c] + s * sp.value[c], std::hypot((1 - s) * d.std_error[c], s * sp.std_error[c])};
  });
}

TEST(LayeredMaterialBake, LayeredOverLambertIsItsClosedFormOfTheCoatsAlbedo) {
  // Layered over a Lambertian base ρ/π: E(μo) = E_s(μo) + (1 − T(μo)) ∫ (1 − T(μi)) ρ/π cos dωi
  //                                            = E_s(μo) + (1 − T(μo)) ρ (1 − T̄),  T̄ = 2 ∫ T(μ) μ dμ,
  // where T is the coat's albedo as the material tabulates it (Material::specular_albedo, the table eval reads) and
  // E_s the coat's true albedo, baked alone with another seed. T̄ is integrated here over T's piecewise-linear
  // interpolation with 2^16 midpoints: error below 1e-9, far under the Monte Carlo σ.
  brdf::MaterialSpec m;
  m.diffuse = lambert(Rgb{0.6, 0.1, 0.05});
  m.specular = ggx(0.2, Rgb{0.04});
  m.combine = brdf::Combine::layered;
  const brdf::Material material(m);
  constexpr int kNodes = 1 << 16;
  Rgb t_avg;
  for (int k = 0; k < kNodes; ++k) {
    const double mu = (k + 0.5) / kNodes;
    t_avg += material.specular_albedo(mu) * (2.0 * mu / kNodes);
  }
  const MaterialBakeResult whole = bake_tables(m, {}, 1);
  const MaterialBakeResult coat = bake_tables({}, m.specular, 2);
  expect_albedo(whole, [&](size_t i, int c) {
    const Rgb t = material.specular_albedo(whole.albedo.mu[i]);
    return Expected{coat.albedo.e[i].value[c] + (1 - t[c]) * m.diffuse.albedo[c] * (1 - t_avg[c]),
                    coat.albedo.e[i].std_error[c]};
  });
}

TEST(LayeredMaterialBake, FurnaceReciprocitySplitSumMerlAndReport) {
  brdf::MaterialSpec m;
  m.diffuse = lambert(Rgb{0.6, 0.1, 0.05});
  m.specular = ggx(0.2, Rgb{0.04});
  MaterialBakeInput in = tables_only(4096);
  in.material = m;
  in.merl = true;
  in.preview = true;
  const MaterialBakeResult r = bake_material(in);

  // The white furnace (both lobes white, Fresnel off) keeps at most the energy it receives: E ≤ E_s + (1 − E_s) ≤ 1.
  EXPECT_TRUE(r.validation.energy.conserves_energy);
  EXPECT_LE(r.validation.energy.white_max_albedo, 1.0 + 3 * r.validation.energy.white_max_albedo_error + 1e-9);
  // It loses what the coat reflects back down (docs/BRDF.md: 4–8 % at f0 = 0.04), but not most of it.
  EXPECT_GT(r.white_furnace.average.value.g, 0.85);
  // f(o, i) and f(i, o) are the same products in another order: equal to rounding.
  EXPECT_TRUE(r.validation.reciprocity.model_claims_reciprocal);
  EXPECT_LT(r.validation.reciprocity.max_relative_difference, 1e-12);
  // The coat's approximations, measured on the coat.
  ASSERT_FALSE(r.validation.approximations.empty());
  for (const auto& a : r.validation.approximations) EXPECT_EQ(a.name.rfind("specular lobe, ", 0), 0u) << a.name;

  // The split-sum table is the coat's: the same entries with the same seeds as the coat's own bake, bit for bit.
  MaterialBakeInput coat_in = tables_only(4096);
  coat_in.model = m.specular;
  coat_in.preview = false;
  const MaterialBakeResult coat = bake_material(coat_in);
  EXPECT_EQ(r.split_sum.scale, coat.split_sum.scale);
  EXPECT_EQ(r.split_sum.bias, coat.split_sum.bias);

  // MERL: each cell holds the material's f at the cell's centre (merl.h), here checked at cells across the table.
  const bake::BakeOutput* merl = find_output(r, "brdf.merl");
  ASSERT_NE(merl, nullptr);
  const MerlTable table = decode_merl(merl->bytes);
  const brdf::Material material(m);
  int checked = 0;
  for (int i_h = 0; i_h < kMerlThetaH; i_h += 11) {
    for (int i_d = 0; i_d < kMerlThetaD; i_d += 13) {
      for (int i_p = 0; i_p < kMerlPhiD; i_p += 37) {
        const double th = std::pow((i_h + 0.5) / kMerlThetaH, 2) * kPi / 2, td = (i_d + 0.5) / kMerlThetaD * kPi / 2;
        const MerlDirections w = merl_directions(th, td, (i_p + 0.5) / kMerlPhiD * kPi);
        if (w.wo.z <= 0 || w.wi.z <= 0) continue;  // below the horizon: the cell's mean above it (merl.h)
        const Rgb f = material.eval(w.wo, w.wi), g = table.at(i_h, i_d, i_p);
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(g[c], f[c], 1e-12 * f[c] + 1e-300) << i_h << " " << i_d << " " << i_p;
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 100);
  EXPECT_NE(find_output(r, "preview.png"), nullptr);

  const std::string& report = find_output(r, "report.json")->bytes;
  EXPECT_NE(report.find("\"name\": \"material\""), std::string::npos);
  EXPECT_NE(report.find("\"combine\": \"layered\""), std::string::npos);
  EXPECT_NE(report.find("\"baker\": \"kiln-material-4\""), std::string::npos);
  EXPECT_NE(r.description.find("layered"), std::string::npos) << r.description;
}

TEST(LayeredMaterialBake, ABadLobeIsNamedByItsPath) {
  MaterialBakeInput in;
  in.material = brdf::MaterialSpec{};
  in.material->specular = ggx(-0.2, Rgb{0.04});
  ASSERT_TRUE(validate(in).has_value());
  EXPECT_EQ(std::string(validate(in)->what()).rfind("material.specular.alpha_x: must be in (0, 1]", 0), 0u)
      << validate(in)->what();
  in.material->specular = ggx(0.2, Rgb{0.04});
  in.material->combine = brdf::Combine::weights;
  in.material->specular_weight = 1.5;
  EXPECT_EQ(std::string(validate(in)->what()).rfind("material.specular_weight:", 0), 0u) << validate(in)->what();
}

}  // namespace
}  // namespace kiln::material
