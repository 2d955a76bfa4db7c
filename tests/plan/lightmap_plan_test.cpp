// The lightmap planner's decisions on scenes built so that the right answer is known: which strategies exist, how
// many bounces an albedo needs, which lobes matter, and that a job's forcing wins and is recorded.
#include "bakers/plan/lightmap_plan.h"

#include "bakers/brdf/albedo.h"
#include "bakers/brdf/material.h"

#include <cmath>
#include <stdexcept>

#include <gtest/gtest.h>

namespace kiln::plan {
namespace {

scene::SceneMaterial lambert(const std::string& name, double albedo, Rgb base = Rgb{1.0}) {
  scene::SceneMaterial m;
  m.name = name;
  m.bsdf.diffuse.model = brdf::Model::lambert;
  m.bsdf.diffuse.albedo = Rgb{albedo};
  m.bsdf.specular.model = brdf::Model::ggx;
  m.bsdf.combine = brdf::Combine::weights;
  m.bsdf.specular_weight = 0.0;  // no specular lobe at all
  m.base_color = base;
  return m;
}

scene::SceneMaterial glossy(const std::string& name, double alpha_x, double alpha_y, double weight) {
  scene::SceneMaterial m = lambert(name, 0.5);
  m.bsdf.specular.alpha_x = alpha_x;
  m.bsdf.specular.alpha_y = alpha_y;
  m.bsdf.specular_weight = weight;
  return m;
}

// One quad (two triangles) per material index given.
scene::Scene quads(std::vector<scene::SceneMaterial> materials, std::vector<uint32_t> used) {
  scene::Scene s;
  s.materials = std::move(materials);
  scene::Mesh mesh;
  mesh.name = "quads";
  for (size_t q = 0; q < used.size(); ++q) {
    const double x = static_cast<double>(q);
    const uint32_t b = static_cast<uint32_t>(mesh.positions.size());
    mesh.positions.insert(mesh.positions.end(), {{x, 0, 0}, {x + 1, 0, 0}, {x + 1, 0, 1}, {x, 0, 1}});
    mesh.indices.insert(mesh.indices.end(), {b, b + 2, b + 1, b, b + 3, b + 2});
    mesh.material.insert(mesh.material.end(), {used[q], used[q]});
  }
  s.meshes.push_back(mesh);
  s.instances.push_back({});
  return s;
}

scene::Light point_light() {
  scene::Light l;
  l.type = scene::LightShape::point;
  l.position = {0, 2, 0};
  l.color = Rgb{10.0};
  return l;
}

const Decision& decision(const LightmapPlan& p, const std::string& effect) {
  for (const Decision& d : p.decisions) {
    if (d.effect == effect) return d;
  }
  throw std::logic_error("no decision " + effect);
}

TEST(LightmapPlan, EveryEffectHasOneDecisionWithAReason) {
  scene::Scene s = quads({lambert("grey", 0.5)}, {0});
  const LightmapPlan p = plan_lightmap(s, {});
  ASSERT_EQ(p.decisions.size(), lightmap_effect_names().size());
  for (size_t i = 0; i < p.decisions.size(); ++i) {
    EXPECT_EQ(p.decisions[i].effect, lightmap_effect_names()[i]);
    EXPECT_FALSE(p.decisions[i].reason.empty()) << p.decisions[i].effect;
    EXPECT_FALSE(p.decisions[i].forced);
  }
}

TEST(LightmapPlan, OnlyTheLightsTheSceneHasAreSampled) {
  scene::Scene s = quads({lambert("grey", 0.5)}, {0});
  s.lights.push_back(point_light());
  scene::Light black = point_light();
  black.type = scene::LightShape::spot;
  black.color = Rgb{0.0};  // no power: not a strategy worth having
  s.lights.push_back(black);
  const LightmapPlan p = plan_lightmap(s, {});
  EXPECT_TRUE(p.point_lights);
  EXPECT_FALSE(p.spot_lights);
  EXPECT_FALSE(p.directional_lights);
  EXPECT_FALSE(p.area_lights);
  EXPECT_FALSE(p.emissive_triangles);
  EXPECT_FALSE(p.environment_sampling);
  EXPECT_FALSE(p.environment_importance_map);
  // Only a delta light: a sampled ray can never hit it, so MIS has nothing to combine.
  EXPECT_FALSE(p.multiple_importance_sampling);
}

TEST(LightmapPlan, EmissiveMaterialsAndAreaLightsEnableMis) {
  scene::SceneMaterial lamp = lambert("lamp", 0.5);
  lamp.emission = Rgb{5.0};
  scene::Scene s = quads({lambert("grey", 0.5), lamp}, {0, 1});
  const LightmapPlan p = plan_lightmap(s, {});
  EXPECT_TRUE(p.emissive_triangles);
  EXPECT_TRUE(p.multiple_importance_sampling);
  EXPECT_NE(decision(p, "emissive_triangles").reason.find("2 triangles"), std::string::npos)
      << decision(p, "emissive_triangles").reason;
}

TEST(LightmapPlan, EnvironmentStrategiesFollowWhatTheEnvironmentIs) {
  scene::Scene s = quads({lambert("grey", 0.5)}, {0});
  s.environment.constant = Rgb{1.0};
  LightmapPlan p = plan_lightmap(s, {});
  EXPECT_TRUE(p.environment_sampling);
  EXPECT_FALSE(p.environment_importance_map) << "a constant environment needs no importance map";

  s.environment.constant.reset();
  s.environment.width = 64;
  s.environment.height = 32;
  s.environment.equirect.assign(64 * 32, Rgb{1.0});
  for (Rgb& c : s.environment.equirect) c = c * 1.2;  // uniform: peak/mean = 1
  p = plan_lightmap(s, {});
  EXPECT_TRUE(p.environment_sampling);
  EXPECT_FALSE(p.environment_importance_map) << decision(p, "environment_importance_map").reason;

  s.environment.equirect[10 * 64 + 20] = Rgb{1e4};  // a sun
  p = plan_lightmap(s, {});
  EXPECT_TRUE(p.environment_importance_map) << decision(p, "environment_importance_map").reason;
}

// ρ_max for Lambert is the albedo times the base colour's largest channel; the planner has it in closed form for
// Lambertian materials (brdf::lambertian_form), so to rounding (1e-12 relative). The rule itself is checked exactly
// against the ρ_max the plan used.
TEST(LightmapPlan, BouncesAreTheFewestThatBringRhoToThePowerBelowTheBudget) {
  for (const double rho_true : {0.1, 0.5, 0.8, 0.95}) {
    for (double target : {0.1, 0.01, 0.001}) {
      scene::Scene s = quads({lambert("a", rho_true, Rgb{1.0, 0.3, 0.1}), lambert("unused", 1.0)}, {0});
      LightmapPlanOptions o;
      o.target_error = target;
      const LightmapPlan p = plan_lightmap(s, o);
      double rho = rho_true;
      EXPECT_NEAR(p.albedo_max, rho, 1e-12 * rho) << "the unused white material must not count";
      rho = p.albedo_max;
      const double budget = target / 4;
      const int k = p.bounces;
      if (k == o.max_bounces) {  // ρ = 0.95 needs more than the cap of 64: the plan says so
        EXPECT_GT(std::pow(rho, k + 1), budget);
        EXPECT_NE(decision(p, "indirect_bounces").reason.find("capped"), std::string::npos);
        continue;
      }
      EXPECT_LE(std::pow(rho, k + 1), budget * (1 + 1e-12)) << rho << " " << target;
      if (k > 0) {
        EXPECT_GT(std::pow(rho, k), budget) << "one bounce fewer would have been enough";
      }
      EXPECT_EQ(p.russian_roulette, k > p.russian_roulette_depth);
    }
  }
}

// Materials that are not Lambertian go through the Monte Carlo estimates: an Oren–Nayar lobe with σ = 0 is Lambert's
// function, so its ρ_max is the albedo times the base colour's largest channel, estimated from 1024 stratified
// samples per μ (the material's own sampling, which keeps a small probability of sampling the weightless specular
// lobe): a relative error of order 1e-3, so 2e-3 relative. And the closed form for a layered pair of Lambertian
// lobes, ρ_s + (1 − ρ_s)² ρ_d·tint, against an independent estimate of the general material's albedo (4096
// samples at μ = 0.5, any μ being the same for this material; 2e-3 relative again).
TEST(LightmapPlan, AlbedoEstimatedForGeneralMaterialsAndClosedForLambertianOnes) {
  scene::SceneMaterial on = lambert("oren-nayar", 0.6, Rgb{1.0, 0.5, 0.25});
  on.bsdf.diffuse.model = brdf::Model::oren_nayar;
  on.bsdf.diffuse.sigma = 0.0;
  EXPECT_NEAR(plan_lightmap(quads({on}, {0}), {}).albedo_max, 0.6, 2e-3 * 0.6);

  scene::SceneMaterial layered = lambert("layered", 0.7, Rgb{0.9, 0.4, 0.2});
  layered.bsdf.specular.model = brdf::Model::lambert;
  layered.bsdf.specular.albedo = Rgb{0.2};
  layered.bsdf.combine = brdf::Combine::layered;
  const LightmapPlan p = plan_lightmap(quads({layered}, {0}), {});
  EXPECT_NEAR(p.albedo_max, 0.2 + 0.8 * 0.8 * 0.7 * 0.9, 1e-12);
  brdf::AlbedoOptions options;
  options.samples = 4096;
  const Rgb e = brdf::directional_albedo(brdf::Material(layered.bsdf), 0.5, options).value;
  const Rgb e_s = Rgb{0.2};                              // the specular lobe's albedo, Lambertian: exact
  const double estimated = e_s.r + 0.9 * (e.r - e_s.r);  // ρ = E_s + tint (E − E_s), red being the largest
  EXPECT_NEAR(p.albedo_max, estimated, 2e-3 * estimated);
  EXPECT_NEAR(p.materials[0].specular_albedo, 0.2, 1e-12);
  EXPECT_EQ(p.materials[0].lobe_distance, 0.0);
}

TEST(LightmapPlan, ABlackSceneNeedsNoBouncesAndNoBaseColour) {
  scene::Scene s = quads({lambert("black", 0.0)}, {0});
  s.textures.push_back({"checker", 2, 1, {Rgb{0.0}, Rgb{1.0}}});
  s.materials[0].base_color_texture = 0;
  const LightmapPlan p = plan_lightmap(s, {});
  EXPECT_EQ(p.bounces, 0);
  EXPECT_FALSE(p.textures) << "with no bounces a base colour cannot change irradiance";
  EXPECT_FALSE(p.specular_interreflection);
}

TEST(LightmapPlan, TexturesOnlyWhenTheyVary) {
  scene::Scene s = quads({lambert("grey", 0.5)}, {0});
  s.textures.push_back({"flat", 2, 2, {Rgb{0.5}, Rgb{0.5}, Rgb{0.5}, Rgb{0.5}}});
  s.materials[0].base_color_texture = 0;
  EXPECT_FALSE(plan_lightmap(s, {}).textures);
  s.textures[0].texels[3] = Rgb{0.9};
  EXPECT_TRUE(plan_lightmap(s, {}).textures);
  // ρ_max includes the texture's brightest texel: 0.5 × 0.9.
  EXPECT_NEAR(plan_lightmap(s, {}).albedo_max, 0.45, 1e-12);  // closed form: see the bounces test
}

// δ is 0 for a "specular" lobe that is itself Lambertian (π f/E = 1 everywhere, so the overlap is exactly 1 per
// sample), near 1 for a mirror-like lobe, and falls as the lobe widens.
TEST(LightmapPlan, LobeDistanceIsZeroForLambertAndFallsWithRoughness) {
  scene::SceneMaterial flat = lambert("flat", 0.5);
  flat.bsdf.specular.model = brdf::Model::lambert;
  flat.bsdf.specular_weight = 0.5;
  scene::Scene s = quads({flat}, {0});
  LightmapPlan p = plan_lightmap(s, {});
  EXPECT_NEAR(p.materials[0].lobe_distance, 0.0, 1e-12);
  EXPECT_FALSE(p.materials[0].glossy);

  double previous = 2;
  for (double alpha : {0.01, 0.1, 0.3, 0.6, 1.0}) {
    s = quads({glossy("g", alpha, alpha, 0.5)}, {0});
    p = plan_lightmap(s, {});
    const double d = p.materials[0].lobe_distance;
    if (alpha == 0.01) {
      EXPECT_GT(d, 0.9) << "a near-mirror lobe overlaps a Lambertian one very little";
    }
    EXPECT_LT(d, previous) << "alpha " << alpha;
    previous = d;
  }
}

TEST(LightmapPlan, GlossyOnlyWhereTheLobeMattersAtTheTarget) {
  // A sharp lobe carrying half the energy matters at any target; a Lambert-like one at a loose target does not.
  scene::Scene s = quads({glossy("sharp", 0.05, 0.05, 0.5), lambert("matte", 0.5)}, {0, 1});
  LightmapPlan p = plan_lightmap(s, {});
  EXPECT_TRUE(p.materials[0].glossy);
  EXPECT_FALSE(p.materials[1].glossy);
  EXPECT_TRUE(p.specular_interreflection);

  s = quads({glossy("faint", 0.9, 0.9, 0.02)}, {0});
  LightmapPlanOptions loose;
  loose.target_error = 0.2;
  p = plan_lightmap(s, loose);
  EXPECT_FALSE(p.materials[0].glossy) << decision(p, "specular_interreflection").reason;
  EXPECT_FALSE(p.specular_interreflection);
}

TEST(LightmapPlan, AnisotropyOnlyForGlossyAnisotropicLobes) {
  scene::Scene s = quads({glossy("brushed", 0.05, 0.3, 0.5)}, {0});
  EXPECT_TRUE(plan_lightmap(s, {}).anisotropy);
  s = quads({glossy("round", 0.1, 0.1, 0.5)}, {0});
  EXPECT_FALSE(plan_lightmap(s, {}).anisotropy);
}

TEST(LightmapPlan, ForcingWinsAndIsRecorded) {
  scene::Scene s = quads({lambert("grey", 0.5)}, {0});
  s.lights.push_back(point_light());
  LightmapPlanOptions o;
  o.force_effects = {{"point_lights", false}, {"indirect_bounces", false}, {"specular_interreflection", true}};
  const LightmapPlan p = plan_lightmap(s, o);
  EXPECT_FALSE(p.point_lights);
  EXPECT_EQ(p.bounces, 0);
  EXPECT_TRUE(decision(p, "point_lights").forced);
  EXPECT_NE(decision(p, "point_lights").reason.find("would have enabled"), std::string::npos);
  // Forced on, but there are no bounces for it to act on.
  EXPECT_FALSE(p.specular_interreflection);

  o.force_effects = {{"no_such_effect", true}};
  try {
    plan_lightmap(s, o);
    FAIL() << "an unknown effect must be refused";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_effect"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("indirect_bounces"), std::string::npos) << "the message lists the names";
  }
}

TEST(LightmapPlan, FullPlanSimulatesEverythingTheSceneHas) {
  scene::Scene s = quads({lambert("grey", 0.5), glossy("g", 0.2, 0.4, 0.5)}, {0});  // g unused
  s.environment.constant = Rgb{1.0};
  LightmapPlanOptions o;
  o.max_bounces = 20;
  const LightmapPlan p = full_plan(s, o);
  EXPECT_EQ(p.bounces, 20);
  EXPECT_TRUE(p.environment_sampling);
  EXPECT_FALSE(p.environment_importance_map) << "no image to build a map from";
  EXPECT_FALSE(p.point_lights) << "a light the scene lacks cannot be sampled";
  EXPECT_TRUE(p.specular_interreflection);
  EXPECT_TRUE(p.anisotropy);
  EXPECT_TRUE(p.textures);
  EXPECT_TRUE(p.russian_roulette);
}

TEST(LightmapPlan, BadOptionsAreRefusedByName) {
  scene::Scene s = quads({lambert("grey", 0.5)}, {0});
  LightmapPlanOptions o;
  o.target_error = 0;
  EXPECT_THROW(plan_lightmap(s, o), std::invalid_argument);
  o.target_error = std::nan("");
  EXPECT_THROW(plan_lightmap(s, o), std::invalid_argument);
  o.target_error = 0.01;
  o.max_bounces = -1;
  EXPECT_THROW(plan_lightmap(s, o), std::invalid_argument);
}

}  // namespace
}  // namespace kiln::plan
