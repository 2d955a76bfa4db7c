// The light interface of the lightmap baker (pbrt-v4 chapter 12 is the model): what next-event estimation and
// multiple importance sampling need from every kind of light.
//
// For a shading point p with unit normal n (world space):
//   sample_li(p, n, u)       a direction wi towards the light with the radiance Li arriving along it and the density
//                            of wi per unit solid angle; nullopt when the light cannot reach p (p behind a one-sided
//                            light, outside a spot's cone, on the light's plane, a black or degenerate light).
//   pdf_li(p, n, wi, hit)    the density sample_li would have produced wi with (for MIS when a BSDF-sampled ray
//                            reaches the light); 0 for delta lights and for directions that miss the light.
//   Le(p, wi, hit)           the radiance seen from p along wi when that ray reaches the light (area lights and
//                            emissive triangles at `hit`; the sun disc and the environment for escaping rays).
//   power(scene_radius)      emitted power (W per channel) to choose among lights; infinite lights (directional,
//                            environment) count what falls on a disc of the scene's bounding radius.
//
// Delta lights (point, spot, directional without a disc) return pdf = 0 and delta = true: their contribution is
// Li·cos θ without division (LightSample::irradiance). n matters only where the strategy depends on it (a constant
// environment is sampled cosine-weighted about n); a zero n means "no surface" (uniform sampling of the sphere).
// Every value returned is finite; nothing returns NaN for p on a light, zero-area or black lights.
//
// The lights: punctual_lights.h (point, spot, directional and sun disc), area_lights.h (rect, disk),
// emissive_triangles.h, environment_light.h; light_sampler.h builds them from a Scene and chooses among them.
// Piecewise-constant distributions: distribution.h. Exact polygon irradiance for references: polygon_irradiance.h.
#pragma once

#include <limits>
#include <memory>
#include <optional>

#include "bakers/math/rgb.h"
#include "bakers/math/sampling.h"
#include "bakers/math/vec3.h"
#include "bakers/scene/light_emission.h"

namespace kiln::scene {

using kiln::luminance;  // bakers/math/rgb.h

// Emission as the lights use it: a colour with a non-finite channel emits nothing, negative channels are 0. (The
// translation layer rejects such input with a message; this keeps hand-built scenes from producing NaN.)
inline Rgb usable_emission(const Rgb& c) {
  if (!c.is_finite()) return Rgb{};
  return {c.r > 0 ? c.r : 0.0, c.g > 0 ? c.g : 0.0, c.b > 0 ? c.b : 0.0};
}

inline constexpr double kInfinity = std::numeric_limits<double>::infinity();

struct LightSample {
  Vec3 wi;         // unit, world space, from p towards the light
  Rgb Li;          // radiance arriving at p from direction wi (delta lights: irradiance at normal incidence)
  double pdf = 0;  // per unit solid angle (includes the choice of an emissive triangle); 0 for delta lights
  bool delta = false;
  double distance = kInfinity;  // from p to `point` (for the shadow ray); infinity for directional and environment
  Vec3 point;                   // the sampled point on the light; infinite lights: wi (they have no point)

  // The one-sample estimate of irradiance from this sample at a surface whose normal makes cos θ with wi:
  // Li cos θ / pdf, or Li cos θ for a delta light. cos θ ≤ 0 contributes nothing.
  Rgb irradiance(double cos_theta) const {
    if (!(cos_theta > 0)) return Rgb{};
    if (delta) return Li * cos_theta;
    return pdf > 0 ? Li * (cos_theta / pdf) : Rgb{};
  }
};

// Where a ray met a light: what pdf_li and Le need beyond p and wi.
struct LightHit {
  Vec3 point;   // the point on the light (area lights, emissive triangles)
  Vec3 normal;  // the light's geometric normal there (any orientation)
  double distance = kInfinity;
  int triangle = -1;  // emissive triangles: the index in the container (EmissiveTriangles::find)
};

// What a LightSource is: one per scene LightShape, a directional light with a disc as a sun, and the two lights
// that are not scene lights (emissive triangles, the environment).
enum class LightSamplerKind { point, spot, directional, sun, rect, disk, emissive_triangles, environment };

class LightSource {
 public:
  virtual ~LightSource() = default;
  virtual LightSamplerKind kind() const = 0;
  virtual bool is_delta() const { return false; }
  // Directional lights and the environment: reached by rays that escape the scene.
  virtual bool is_infinite() const { return false; }

  virtual std::optional<LightSample> sample_li(const Vec3& p, const Vec3& n, Point2 u) const = 0;
  virtual double pdf_li(const Vec3& /*p*/, const Vec3& /*n*/, const Vec3& /*wi*/, const LightHit& /*hit*/) const {
    return 0.0;
  }
  virtual Rgb Le(const Vec3& /*p*/, const Vec3& /*wi*/, const LightHit& /*hit*/) const { return Rgb{}; }
  // Analytic lights that are not scene geometry (rect, disk): the nearest hit of the ray p + t·wi, 0 < t < t_max.
  virtual std::optional<LightHit> intersect(const Vec3& /*p*/, const Vec3& /*wi*/, double /*t_max*/) const {
    return std::nullopt;
  }
  virtual Rgb power(double scene_radius) const = 0;
  // Light tracing: a ray leaving the light from the quasi-random numbers u_position and u_direction (light_emission.h);
  // nullopt for a ray that carries nothing. Lights that cannot start rays (infinite lights) answer false to
  // emits_rays() and always nullopt.
  virtual bool emits_rays() const { return false; }
  virtual std::optional<LightEmission> sample_le(Point2 /*u_position*/, Point2 /*u_direction*/) const {
    return std::nullopt;
  }
  // True when sample_li at p is uniform in the solid angle the light subtends there (a spherical rectangle, a sun
  // disc): light sampling then leaves only the variation of cos θ, and the transport lets it own the light rather
  // than combine it with BSDF sampling, whose rare hits on a small light only add skewed variance.
  virtual bool uniform_in_solid_angle(const Vec3& /*p*/) const { return false; }
};

}  // namespace kiln::scene
