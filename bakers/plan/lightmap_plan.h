// The lightmap planner: reads a scene before baking and decides which effects (lightmap_effect.h) to simulate,
// recording why, so that a bake pays only for what can change its answer at the target error. The transport
// (bakers/lightmap) simulates exactly what the plan enables; a job forces any effect on or off by name.
//
// Each pruning may bias the bake by at most a quarter of the target relative error. Bounces: the fewest k with
// ρ_max^(k+1) ≤ target/4, ρ_max the largest directional albedo of a used material. A specular lobe is simulated as
// itself where replacing it by a Lambertian lobe of the same albedo could change reflected light by more than that
// (2 w_s Ē_s δ, δ the total-variation distance between the two lobes' normalised distributions).
//
// The rule for each effect and the derivation of the budget: docs/LIGHTMAP.md, section "The planner".
#pragma once

#include <map>
#include <string>
#include <vector>

#include "bakers/plan/decision.h"
#include "bakers/plan/lightmap_effect.h"
#include "bakers/plan/media_analysis.h"
#include "bakers/scene/scene.h"

namespace kiln::plan {

struct LightmapPlanOptions {
  double target_error = 0.01;  // relative, (0, 1]
  int max_bounces = 64;        // cap on `bounces`, [0, 1024]
  std::map<std::string, bool> force_effects;
  // What the bake is asked for beyond irradiance, as far as it decides how light is simulated: the SH output needs
  // the direction of all the light a texel's paths gather; the texel error metric asks the same relative error of
  // every texel.
  bool directional = false;
  bool per_texel_error = false;
  // The bake samples its pages a tile at a time to fit its memory limit (lightmap_bake.h): light tracing, which
  // deposits into any texel of any page, would need its sums for every texel at once.
  bool tiled = false;
  // Participating media (docs/MEDIA.md): as the job gives them, and built (the same order). The planner decides
  // whether they are simulated, and how (MediaMode); light tracing does not track its rays through them.
  const std::vector<volume::MediumInput>* media_inputs = nullptr;
  std::vector<const volume::Medium*> media;
};

// How participating media are simulated: not at all (absent, outside the scene, or too thin to matter), as
// attenuation only (every ray's transmittance, no scattering: the light they scatter is left out), or in full (free
// flights, in-scattering, multiple scattering up to the bounce count).
enum class MediaMode { none, attenuation, scattering };
const char* to_string(MediaMode mode);

// What the planner found out about one material of the scene.
struct MaterialAnalysis {
  std::string name;
  bool used = false;           // some triangle of some mesh refers to it
  double albedo_max = 0;       // max over μ and channels of the directional albedo, base colour × texture maximum
  double specular_albedo = 0;  // w_s Ē_s: the specular lobe's weighted average albedo
  double lobe_distance = 0;    // δ (see the top of this file); 0 if the lobe has no albedo
  bool glossy = false;         // its specular lobe is simulated as itself in bounces
  bool anisotropic = false;    // its specular lobe has α_x ≠ α_y
  bool textured = false;       // a base-colour texture that is not uniform
};

struct LightmapPlan {
  std::vector<Decision> decisions;  // one per effect, in the order of lightmap_effects()

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
  // Indirect light by rays from the lights (bakers/lightmap/light_tracing.h); texels then gather direct light only.
  bool light_tracing = false;
  MediaMode media_mode = MediaMode::none;
  std::vector<int> media;                   // indices into the options' media of those simulated (none: empty)
  MediaAnalysis media_analysis;             // what the decision was made from
  double albedo_max = 0;                    // ρ_max over the used materials
  std::vector<MaterialAnalysis> materials;  // parallel to Scene::materials

  bool enabled(LightmapEffect effect) const;
  bool enabled(const std::string& effect) const;  // by the effect's name
};

// Throws bake::InvalidInput for unknown force_effects names, options out of range or an invalid material.
LightmapPlan plan_lightmap(const scene::Scene& scene, const LightmapPlanOptions& options);

// Every effect the scene has, simulated: the reference a planned bake is compared against. Bounces are
// options.max_bounces; force_effects is ignored.
LightmapPlan full_plan(const scene::Scene& scene, const LightmapPlanOptions& options);

}  // namespace kiln::plan
