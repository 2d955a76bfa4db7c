// The closed Lambertian form the integrator shades with (brdf::lambertian_form): the same function as the general
// Material it replaces, and the same bake.
#include <gtest/gtest.h>

#include <cmath>

#include "bakers/brdf/material.h"
#include "bakers/lightmap/lightmap_bake.h"
#include "bakers/math/constants.h"
#include "bakers/math/rng.h"
#include "bakers/math/sampling.h"
#include "tests/support/test_scenes.h"

namespace kiln::lightmap {
namespace {

brdf::MaterialSpec two_lamberts(brdf::Combine combine, Rgb rho_d, Rgb rho_s, double specular_weight) {
  brdf::MaterialSpec spec;
  spec.diffuse.model = spec.specular.model = brdf::Model::lambert;
  spec.diffuse.albedo = rho_d;
  spec.specular.albedo = rho_s;
  spec.combine = combine;
  spec.specular_weight = specular_weight;
  return spec;
}

// (A + B·tint)/π against Material::eval at 200 random direction pairs and tints, to 1e-12 relative.
void expect_same_function(const brdf::LambertianForm& form, const brdf::MaterialSpec& spec, Pcg32& rng) {
  const brdf::Material material(spec);
  for (int i = 0; i < 200; ++i) {
    const Vec3 wo = sample_cosine_hemisphere({rng.uniform(), rng.uniform()});
    const Vec3 wi = sample_cosine_hemisphere({rng.uniform(), rng.uniform()});
    const Rgb tint{rng.uniform(), rng.uniform(), rng.uniform()};
    const Rgb want = material.eval(wo, wi, tint);
    const Rgb got = (form.A + form.B * tint) * kInvPi;
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], want[c], 1e-12 * want[c]) << material.describe();
  }
}

// For both combinations, random direction pairs and tints: (A + B·tint)/π equals Material::eval. Weights: exact up
// to rounding (1e-12 relative). Layered: Material weighs the diffuse lobe by its tabulated E_s, a Monte Carlo
// albedo table; for a Lambertian lobe every cosine-weighted sample returns ρ_s exactly, so the table is ρ_s to
// rounding too (1e-12; a looser agreement would mean the table is not what lambertian_form assumes).
TEST(LambertianForm, EqualsTheMaterialItStandsFor) {
  Pcg32 rng(7);
  for (const brdf::Combine combine : {brdf::Combine::weights, brdf::Combine::layered}) {
    const brdf::MaterialSpec spec = two_lamberts(combine, Rgb{0.7, 0.5, 0.2}, Rgb{0.1, 0.3, 0.05}, 0.25);
    const auto form = brdf::lambertian_form(spec);
    ASSERT_TRUE(form.has_value());
    expect_same_function(*form, spec, rng);
  }
}

// A weightless specular lobe of another model (how glTF-less imports and the tests' plain Lambert materials come)
// leaves the diffuse lobe alone: A = 0, B = ρ_d, equal to Material::eval to rounding.
TEST(LambertianForm, AWeightlessSpecularLobeOfAnyModelIsLambertian) {
  Pcg32 rng(9);
  for (const brdf::Model model : {brdf::Model::ggx, brdf::Model::cook_torrance, brdf::Model::oren_nayar}) {
    brdf::MaterialSpec spec = two_lamberts(brdf::Combine::weights, Rgb{0.7, 0.5, 0.2}, Rgb{0.5}, 0.0);
    spec.specular.model = model;
    spec.specular.alpha_x = spec.specular.alpha_y = 0.2;
    const auto form = brdf::lambertian_form(spec);
    ASSERT_TRUE(form.has_value());
    EXPECT_EQ(form->A, Rgb{0.0});
    expect_same_function(*form, spec, rng);
  }
}

TEST(LambertianForm, OnlyForTwoLambertianLobes) {
  brdf::MaterialSpec spec = two_lamberts(brdf::Combine::weights, Rgb{0.5}, Rgb{0.5}, 0.5);
  spec.specular.model = brdf::Model::ggx;
  EXPECT_FALSE(brdf::lambertian_form(spec).has_value());
  spec = two_lamberts(brdf::Combine::weights, Rgb{0.5}, Rgb{0.5}, 0.5);
  spec.diffuse.model = brdf::Model::oren_nayar;
  EXPECT_FALSE(brdf::lambertian_form(spec).has_value());
  spec.specular_weight = 0.0;  // weightless specular, but the diffuse lobe itself is not Lambertian
  EXPECT_FALSE(brdf::lambertian_form(spec).has_value());
  spec = two_lamberts(brdf::Combine::layered, Rgb{0.5}, Rgb{0.5}, 0.0);
  spec.specular.model = brdf::Model::ggx;  // layered: the weight does not apply, the GGX interface does
  EXPECT_FALSE(brdf::lambertian_form(spec).has_value());
}

// The furnace, shaded both ways: inside a closed sphere of albedo ρ = 0.8 emitting L_e = 1, E = π/(1 − ρ)
// everywhere. The walls are Lambertian in closed form, or an Oren–Nayar material with σ = 0 (the same function, shaded
// through the general BSDF, as the report's vertex count confirms). Budget-bound bakes (every texel exactly 128
// estimates: no adaptive stopping, so no stopping bias) pooled over all texels: the mean of E/E_exact is within 4
// pooled standard errors of 1, a bias of the kind a wrong fast path shows (a lost bounce is −20 % here) far outside.
TEST(LambertianForm, TheFurnaceComesOutTheSameShadedEitherWay) {
  constexpr double rho = 0.8;
  for (const bool closed_form : {true, false}) {
    scene::Scene s;
    scene::SceneMaterial walls = test::lambert_material("glow", rho, Rgb{1.0});
    if (!closed_form) {
      walls.bsdf.diffuse.model = brdf::Model::oren_nayar;
      walls.bsdf.diffuse.sigma = 0.0;
    }
    s.materials.push_back(walls);
    test::add_sphere(s, "sphere", {0, 0, 0}, 1.0, 12, 0, /*inward=*/true, /*smooth=*/false);
    LightmapBakeInput in = test::lightmap_input(s, 12, 1e-4);
    in.min_samples = in.max_samples = 128;
    in.full_simulation = true;  // every bounce to max_bounces, with roulette
    const LightmapBakeResult r = bake_lightmaps(in);
    if (closed_form) {
      EXPECT_EQ(r.general_vertices, 0u);
    } else {
      EXPECT_GT(r.general_vertices, 0u);
    }
    const image::FloatImage E = test::exr_output(r, "sphere_irradiance.exr");
    const image::FloatImage err = test::exr_output(r, "sphere_error.exr");
    const image::FloatImage valid = test::exr_output(r, "sphere_validity.exr");
    const double exact = kPi / (1 - rho);
    double sum = 0, variance = 0;
    int n = 0;
    for (int y = 0; y < E.height; ++y) {
      for (int x = 0; x < E.width; ++x) {
        if (valid.at(x, y, 0) != 1.0f) continue;
        const double ratio = E.at(x, y, 1) / exact;
        sum += ratio;
        variance += std::pow(ratio * err.at(x, y, 0), 2);
        ++n;
      }
    }
    ASSERT_GT(n, 50);
    const double mean = sum / n, standard_error = std::sqrt(variance) / n;
    EXPECT_NEAR(mean, 1.0, 4 * standard_error) << (closed_form ? "closed form" : "general BSDF");
  }
}

}  // namespace
}  // namespace kiln::lightmap
