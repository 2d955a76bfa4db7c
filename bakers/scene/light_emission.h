// Rays leaving a light, for light tracing (bakers/lightmap/light_tracing.h): where a ray starts, where it goes, and
// the flux it carries, Le cos θ / pdf (pdf: of the point by area times of the direction by solid angle, times the
// probability of the side for two-sided emitters). Summed over N rays and divided by N, the weights of the rays that
// reach a surface element estimate the flux the light sends there.
#pragma once

#include <optional>

#include "bakers/math/constants.h"
#include "bakers/math/rgb.h"
#include "bakers/math/sampling.h"
#include "bakers/math/vec3.h"

namespace kiln::scene {

struct LightEmission {
  Vec3 origin;
  Vec3 direction;     // unit
  Vec3 ng;            // the emitting side's unit normal; zero for point lights
  double offset = 0;  // lift off the emitting surface when it is scene geometry (ray_offset.h); 0 otherwise
  Rgb weight;         // Le cos θ / pdf
};

// A direction leaving a Lambertian emitter of unit front normal `front`, cosine-distributed about the emitting
// side's normal: the front, or (two-sided) either side with probability 1/2, chosen by u.x (then reused). Sets
// direction and ng; returns the factor weight = L_e · factor: π / p(side). nullopt on the hemisphere's rim (cos θ = 0
// carries nothing).
inline std::optional<double> lambertian_emission(const Vec3& front, bool two_sided, Point2 u, LightEmission& e) {
  e.ng = front;
  if (two_sided) {
    const bool back = u.x < 0.5;
    u.x = back ? 2 * u.x : 2 * u.x - 1;
    if (back) e.ng = -front;
  }
  const Vec3 local = sample_cosine_hemisphere(u);
  if (!(local.z > 0)) return std::nullopt;
  e.direction = Frame::from_normal(e.ng).from_local(local);
  return kPi * (two_sided ? 2.0 : 1.0);
}

}  // namespace kiln::scene
