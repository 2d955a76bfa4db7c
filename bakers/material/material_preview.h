// preview.png of a material bake: three spheres of the material side by side, seen head-on by an orthographic
// camera, so that a person sees at a glance what the tables describe.
//
//   studio   under a neutral studio environment (a dim floor, a brighter ceiling and two large soft boxes, a key
//            light upper left and a fill light right), smooth everywhere: the highlights show the lobe's shape;
//   sun      under a sun (a delta light of irradiance kSunIrradiance, upper right) and a dim uniform sky: the
//            diffuse falloff, the specular highlight and, at grazing angles, the Fresnel rise;
//   furnace  the white-furnace form (F = 1, white: the material bake's `white` model) inside a uniform environment
//            of radiance 1: each pixel is the directional albedo E(μ) at its μ = n·v, exposed so that 1 (energy
//            kept) is linear 0.5 and anything brighter is energy gained. A perfectly conserving model is a flat
//            disc; microfacet models darken towards the rim by the energy their single scattering loses.
//
// Each pixel estimates L_o = ∫ f(wo, wi) L_i(wi) cos θ_i dω_i with the model's own importance sampling over
// Owen-scrambled Sobol points (a smooth environment needs nothing else), plus, for the sun, its exact delta term
// f(wo, w_sun) E cos θ_sun. Shading is in the local frame of the sphere's normal (normal along +z), wo the
// direction to the camera. The radiance goes through OpenColorIO's display transform into an 8-bit sRGB PNG.
#pragma once

#include <atomic>
#include <cstdint>
#include <vector>

#include "bakers/bake/output.h"
#include "bakers/brdf/bxdf.h"
#include "bakers/math/vec3.h"

namespace kiln::material {

inline constexpr double kSunIrradiance = 3.0;  // W·m⁻² at normal incidence
inline constexpr double kSkyRadiance = 0.1;    // the sun panel's uniform sky
inline constexpr double kFurnaceExposure = 0.5;

struct PreviewOptions {
  int sphere_pixels = 160;     // each sphere's diameter (and the image's height), [8, 1024]
  int samples_per_pixel = 64;  // [1, 1 << 16]
  uint32_t seed = 1;
};

// Linear radiance, RGB, 3·S wide and S high (S = sphere_pixels), row-major, top row first: the studio, sun and
// furnace panels left to right. Pixels off the spheres are kBackground.
struct PreviewImage {
  int width = 0, height = 0;
  std::vector<float> rgb;
  static constexpr float kBackground = 0.02f;
};

// The studio environment's radiance towards direction `w` (world space, +Y up, the camera looks along −Z).
double studio_radiance(const Vec3& w);
// The direction towards the sun panel's sun (world space).
Vec3 sun_direction();

// `material` for the studio and sun panels, `white_furnace` for the furnace panel. Throws bake::BakeCancelled when
// `cancel` is set (checked every row).
PreviewImage render_preview(const brdf::Bxdf& material, const brdf::Bxdf& white_furnace, const PreviewOptions& options,
                            const std::atomic<bool>* cancel = nullptr);

// preview.png: the studio and sun panels at exposure 1, the furnace panel at kFurnaceExposure, through the active
// OpenColorIO config's display transform from `color_space` (the working space the material's colours are in).
bake::BakeOutput preview_output(const PreviewImage& image, const std::string& color_space);

}  // namespace kiln::material
