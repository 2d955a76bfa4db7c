// The lightmap planner: reads a scene before baking and decides which effects to simulate, recording why, so that a
// bake pays only for what can change its answer at the target error (issue 5, "simulate only the effects a scene
// calls for"). The transport (bakers/lightmap) simulates exactly what the plan enables; a job forces any effect on or
// off by name.
//
// ## Effects and rules (names are stable: reports and force_effects use them)
//   point_lights, spot_lights, directional_lights, area_lights, emissive_triangles
//       next-event estimation for each kind of light the scene has (with non-zero power); none without them.
//   environment_sampling        next-event estimation of the environment; off without one.
//   environment_importance_map  a 2-D luminance distribution over the environment image; off for a constant
//                               environment (cosine sampling is then the ideal strategy for irradiance) and for an
//                               image whose luminance varies by less than the target error.
//   multiple_importance_sampling  cosine (BSDF) sampling combined with light sampling by the balance heuristic;
//                               only when some light can be hit by a ray (area, emissive, environment, a sun disc).
//   indirect_bounces            light reflected by surfaces before reaching a texel (`bounces` ≥ 1).
//   specular_interreflection    bounces off a material evaluate its specular lobe as itself; off, the lobe is
//                               replaced by a Lambertian lobe of the same directional albedo (decided per material).
//   anisotropy                  α_x ≠ α_y evaluated as given; off, an anisotropic lobe uses α = √(α_x α_y).
//   textures                    base-colour textures sampled at hit points; off, each uses its average.
//   russian_roulette            paths longer than `russian_roulette_depth` continue with probability of their
//                               throughput (unbiased); only when `bounces` exceeds that depth.
//
// ## The error budget
// Each pruning introduces a bias; the planner allows each at most a quarter of the target relative error, so that
// the pruned bake stays within the target even with its noise (quadrature sum of noise at the target and biases
// at a quarter of it: ≤ 1.06 × the target with two biases active).
//
// Bounces: with ρ_max the largest directional albedo of any material (any direction, any channel, base colour and
// textures included), light reflected j times carries at most ρ_max^j of the emitted radiance, so the light that
// needs more than k reflections is at most the fraction ρ_max^(k+1) of the total. A closed furnace is the worst case:
// the total is L_e/(1 − ρ), the truncated sum L_e(1 − ρ^(k+1))/(1 − ρ), a relative shortfall of ρ^(k+1). The plan takes
// the smallest k with ρ_max^(k+1) ≤ target/4, capped at options.max_bounces (and says what bias the cap leaves).
//
// Specular lobes: replacing a lobe f_s of directional albedo E_s(wo) by the Lambertian E_s(wo)/π changes the
// radiance the surface reflects by at most 2 E_s δ of the largest incident radiance, where δ ∈ [0, 1] is the
// total-variation distance between the two normalised reflected distributions, ½∫|f_s cos/E_s − cos/π| dω_i,
// averaged over wo (cosine-weighted). The lobe is simulated as itself where w_s · 2 Ē_s δ > target/4 (w_s its weight
// in the material). δ is estimated as 1 − E[min(π f_s/E_s, 1)] under cosine sampling: a bounded integrand, so a few
// thousand samples give it to about 0.01.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "bakers/plan/decision.h"
#include "bakers/scene/scene.h"

namespace kiln::plan {

struct LightmapPlanOptions {
  double target_error = 0.01;  // relative, (0, 1]
  int max_bounces = 64;        // cap on `bounces`, [0, 1024]
  std::map<std::string, bool> force_effects;
};

// What the planner found out about one material of the scene.
struct MaterialAnalysis {
  std::string name;
  bool used = false;             // some triangle of some mesh refers to it
  double albedo_max = 0;         // max over μ and channels of the directional albedo, base colour × texture maximum
  double specular_albedo = 0;    // w_s Ē_s: the specular lobe's weighted average albedo
  double lobe_distance = 0;      // δ above (0 if the lobe has no albedo)
  bool glossy = false;           // its specular lobe is simulated as itself in bounces
  bool anisotropic = false;      // its specular lobe has α_x ≠ α_y
  bool textured = false;         // a base-colour texture that is not uniform
};

struct LightmapPlan {
  std::vector<Decision> decisions;  // one per effect, in the order of lightmap_effect_names()

  bool point_lights = false, spot_lights = false, directional_lights = false, area_lights = false;
  bool emissive_triangles = false;
  bool environment_sampling = false, environment_importance_map = false;
  bool multiple_importance_sampling = false;
  int bounces = 0;                        // reflections before the texel: 0 = direct light only
  bool specular_interreflection = false;  // per material: materials[i].glossy
  bool anisotropy = false;
  bool textures = false;
  bool russian_roulette = false;
  int russian_roulette_depth = 3;  // bounces taken with certainty before the roulette starts
  double albedo_max = 0;           // ρ_max over the used materials
  std::vector<MaterialAnalysis> materials;  // parallel to Scene::materials

  bool enabled(const std::string& effect) const;
};

std::vector<std::string> lightmap_effect_names();

// Throws std::invalid_argument for unknown force_effects names or options out of range.
LightmapPlan plan_lightmap(const scene::Scene& scene, const LightmapPlanOptions& options);

// Every effect the scene has, simulated: the reference a planned bake is compared against. Bounces are
// options.max_bounces; force_effects is ignored.
LightmapPlan full_plan(const scene::Scene& scene, const LightmapPlanOptions& options);

}  // namespace kiln::plan
