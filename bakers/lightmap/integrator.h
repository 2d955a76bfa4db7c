// Light transport for lightmaps: one-sample estimates of the irradiance E = ∫ L(ω) cos θ dω arriving at a texel's
// sample point, by path tracing with next-event estimation at every vertex, combined with cosine/BSDF sampling by
// multiple importance sampling (balance heuristic), as the plan (bakers/plan/lightmap_plan.h) allows.
//
// At the texel (the receiver, a white Lambertian "sensor" with f = 1/π scaled by π, i.e. weight cos θ):
//   - light sampling: one light chosen by power, one point on it; unoccluded: Li cos θ / (pmf · pdf) × w_light;
//   - cosine sampling: one direction ω ~ cos θ/π; the radiance arriving along it, times π, × w_bsdf for what the ray
//     sees of a light (emissive triangle, rect or disk light, sun disc, environment), unweighted for the light
//     reflected by the surface it hits (estimated by the same two strategies at that vertex, recursively, up to
//     plan.bounces reflections, with Russian roulette after plan.russian_roulette_depth).
// Delta lights (points, spots, delta suns) are reached only by light sampling (w = 1).
// With media (ctx.medium), every ray segment samples a free flight by delta tracking (volume/tracking.h): a
// scattering event is a path vertex with next-event estimation through the phase function and phase sampling,
// combined by the balance heuristic; shadow rays carry ratio-tracking transmittance; a scattering counts as a bounce.
// Everything returned is finite: a non-finite contribution (a bug, or an input the scene check missed) is dropped and
// counted, never accumulated.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "bakers/brdf/material.h"
#include "bakers/math/rgb.h"
#include "bakers/math/vec3.h"
#include "bakers/plan/lightmap_plan.h"
#include "bakers/scene/ray_offset.h"
#include "bakers/scene/scene.h"

namespace kiln::scene {
class Tracer;
class SceneLights;
}  // namespace kiln::scene
namespace kiln::volume {
class Medium;
}  // namespace kiln::volume

namespace kiln::lightmap {

class PathSampler;
class RayLog;

// A scene material as the transport evaluates it, after the plan's substitutions (a specular lobe the planner pruned
// is a Lambertian lobe of the same average albedo; an anisotropic one the plan does not evaluate is isotropic).
struct ShadingMaterial {
  // Set when the material is Lambertian whatever the directions (brdf::lambertian_form): shaded in closed form,
  // f = (A + B·tint)/π with cosine sampling (the same function as the general material, a fraction of the cost).
  std::optional<brdf::LambertianForm> lambertian;
  std::unique_ptr<brdf::Material> bsdf;  // the general material, when `lambertian` is not set
  Rgb base_color{1.0};
  int texture = -1;          // into Scene::textures, or -1 (also when the plan does not sample textures)
  Rgb texture_average{1.0};  // used instead of the texture when the plan says so
  Rgb emission{0.0};
  bool emissive = false;  // emission.max() > 0, tested at every hit
  Rgb rho{0.0};  // with `lambertian` and no texture: A + B·base_color·texture_average, the albedo at every point
  bool two_sided = false;
};

// Builds the shading materials for every scene material under the plan.
std::vector<ShadingMaterial> shading_materials(const scene::Scene& scene, const plan::LightmapPlan& plan);

struct TransportContext {
  const scene::Scene* scene = nullptr;  // the cleaned scene the tracer was built from
  const scene::Tracer* tracer = nullptr;
  const scene::SceneLights* lights = nullptr;  // built with the plan's light-sampling decisions
  const plan::LightmapPlan* plan = nullptr;
  const std::vector<ShadingMaterial>* materials = nullptr;
  double ao_distance = 0;     // > 0: a cosine ray that travels this far counts as unoccluded
  bool directional = false;   // estimate the SH of incoming radiance too (IrradianceEstimate::sh; else left zero)
  RayLog* ray_log = nullptr;  // benchmarks only (ray_log.h): receives every ray traced
  // Participating media (docs/MEDIA.md): `medium` is what paths are tracked through (the one medium, or a
  // volume::MediumSum of several) and `media` each medium, for the phase function where they overlap. Null: no
  // media, and the walk is exactly the one without them (a separate instantiation, no test on any ray).
  const volume::Medium* medium = nullptr;
  std::vector<const volume::Medium*> media;
  // False: attenuation only (the plan's MediaMode::attenuation): every segment and shadow ray is attenuated by its
  // transmittance, and nothing scatters or emits.
  bool media_scattering = true;
  // Filled by prepare_context():
  std::vector<int> analytic_lights;  // indices into `lights` of rect and disk lights (not scene geometry)
  bool has_analytic_lights = false;  // !analytic_lights.empty(), tested on every ray
  int emissive_light = -1;           // index of the emissive triangles in `lights`, −1 if none
  bool textured = false;             // some material samples its texture at hit points (texture UVs needed)
};

// Fills the context's light indices from ctx.lights and `textured` from ctx.materials.
void prepare_context(TransportContext& ctx);

// The point a texel sample stands on.
struct Receiver {
  // The world position (already moved out of geometry by the leak pass), the unit geometric normal on the side the
  // lightmap faces, and the lift off the surface that clears its float error (scene/ray_offset.h).
  scene::SurfacePoint surface;
  Vec3 ns;  // shading normal, unit, same hemisphere as surface.ng
};

struct IrradianceEstimate {
  Rgb E;          // irradiance, W/m²
  Rgb sh[4];      // order-1 SH of incoming radiance: Y00, Y1-1, Y10, Y11 (real, orthonormal), when
                  // the context asks for it
  double ao = 0;  // 1 if the cosine ray escaped ao_distance, else 0
  uint32_t rays = 0;
  uint32_t occlusion_rays = 0;    // of `rays`, the shadow (any-hit) queries; the others are closest-hit
  uint32_t general_vertices = 0;  // path vertices shaded through the general BSDF (not in closed Lambertian form)
  bool dropped = false;           // a non-finite contribution was discarded
};

// One sample of every estimate at `r`, with `sampler` supplying the random numbers (path_sampler.h).
IrradianceEstimate estimate_irradiance(const TransportContext& ctx, const Receiver& r, PathSampler& sampler);

// One sample of the order-2 SH of the radiance arriving at a free point p (a light probe: no surface there), by the
// same transport: the probe is an isotropic sensor, estimated by next-event estimation (lights sampled about +Y) and
// a uniformly sampled direction, combined by the balance heuristic. Real orthonormal SH in world coordinates:
// Y00; Y1−1 ∝ y, Y10 ∝ z, Y11 ∝ x; Y2−2 ∝ xy, Y2−1 ∝ yz, Y20 ∝ 3z² − 1, Y21 ∝ xz, Y22 ∝ x² − y².
struct ProbeEstimate {
  Rgb sh[9];
  bool back_face = false;  // the sampled direction's first hit is a back face (a probe inside geometry sees them)
  uint32_t rays = 0;
  bool dropped = false;  // a non-finite contribution was discarded (sh left zero)
};
ProbeEstimate estimate_probe(const TransportContext& ctx, const Vec3& p, PathSampler& sampler);

}  // namespace kiln::lightmap
