// A picture of what an environment bake did, for a person to look at: a row of spheres lit by the bake's outputs with
// the split-sum model, over the environment itself, display-transformed and encoded as PNG.
//
// ## Layout (kPreviewWidth × kPreviewHeight = 640 × 160 pixels)
// - Background: the environment (the chain's first level, the mirror in a bake) as a cylindrical panorama with square
//   pixels: longitude over the whole width, in the equirectangular convention of cubemap.h (u = (x + ½)/640, the
//   centre column looks along −Z and u grows towards +X), latitude from +45° (top) to −45° (bottom), so 0.5625° per
//   pixel both ways.
// - Six spheres of radius kPreviewSphereRadius = 48 px, centred at x = (i + ½)·640/6, y = 80 (i = 0…5), seen by an
//   orthographic camera looking along −Z. On a sphere, with (a, b) = ((x − cx)/R, (cy − y)/R) (image rows grow down,
//   +Y is up): n = (a, b, √(1 − a² − b²)), v = +Z (towards the camera), r = 2(n·v)n − v, μ = n·v.
//   - Spheres 0…4: metal, f0 = PreviewOptions::f0 (default 1: a white metal, whose colour is the lighting itself), at
//     perceptual roughness ρ = 0, 0.25, 0.5, 0.75, 1 (kPreviewRoughness):
//         specular = L_pre(r, ρ) · (f0 · scale(μ, ρ) + bias(μ, ρ)),
//     L_pre read from the chain bilinearly on each level and linearly between the two levels whose roughness brackets
//     ρ (ρ outside the chain's range reads its first or last level); scale and bias bilinear between the DFG table's
//     texel centres (clamped at its borders).
//   - Sphere 5: diffuse, albedo PreviewOptions::diffuse_albedo (default 1, an ideal white), lit by the irradiance cube:
//         diffuse = albedo · E(n) / π.
// - Every pixel (x, y) is the mean of 4 × 4 sub-pixel samples at (x + (i + ½)/4, y + (j + ½)/4), i, j = 0…3, each
//   shading the sphere whose disc (distance ≤ R, boundary included) holds it or else the background: silhouettes are
//   antialiased, and a pixel whose square lies wholly inside a disc is pure sphere.
//
// ## Exposure and display (the rules of bakers/image/display_png.h, shared with the lightmap preview)
// Automatic exposure (unless PreviewOptions::exposure is given): the multiplier that maps the median luminance of the
// background pixels (Rec.709 luma weights 0.2126, 0.7152, 0.0722, kiln's working space) to mid-grey 0.18. A black
// median falls back to the mean, a black environment to exposure 1. The exposed scene-linear values then go through
// the active OpenColorIO config's display/view transform from `color_space` (default display and view: kiln's
// "sRGB"/"Standard" = clamp to [0, 1] and the sRGB curve) and are quantised as round(255 · clamp(v, 0, 1)); a value
// that is not a number anywhere along the way (or is negative before the transform) becomes 0, so the PNG never
// holds a NaN.
// The PNG's text chunks record the exposure ("kiln:exposure" multiplier, "kiln:exposure_ev" = log2 of it,
// "kiln:exposure_rule"), the display/view, the colour space and a description of the spheres ("Description").
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "bakers/envmap/cubemap.h"
#include "bakers/envmap/dfg.h"
#include "bakers/envmap/prefilter.h"
#include "bakers/image/display_png.h"

namespace kiln::envmap {

inline constexpr int kPreviewWidth = 640;
inline constexpr int kPreviewHeight = 160;
inline constexpr int kPreviewSpheres = 6;  // five specular, one diffuse
inline constexpr double kPreviewSphereRadius = 48.0;
inline constexpr int kPreviewSupersampling = 4;  // 4 × 4 sub-pixel samples
inline constexpr std::array<double, 5> kPreviewRoughness = {0.0, 0.25, 0.5, 0.75, 1.0};
inline constexpr double kPreviewMidGrey = image::kMidGrey;  // 0.18

// Centre of sphere i (0…5) in pixel coordinates (x right, y down; pixel (x, y) covers [x, x + 1) × [y, y + 1)).
inline double preview_sphere_center_x(int i) { return (i + 0.5) * kPreviewWidth / kPreviewSpheres; }
inline constexpr double kPreviewSphereCenterY = kPreviewHeight / 2.0;

struct PreviewOptions {
  double f0 = 1.0;                 // specular spheres' reflectance at normal incidence, in [0, 1]
  double diffuse_albedo = 1.0;     // the diffuse sphere's albedo, in [0, 1]
  std::optional<double> exposure;  // a finite multiplier > 0; nullopt: automatic (above)
  std::string display, view;       // OpenColorIO display and view; empty: the config's defaults
};

// The PNG bytes of the preview. `chain[k]` is the prefiltered cube at perceptual roughness `roughness[k]`
// (strictly increasing, in [0, 1]); `irradiance` holds E(n); `dfg` is the split-sum table (dfg.h) over (μ, ρ);
// `color_space` names the space the cubes are in (a space or role of the active config). Throws
// std::invalid_argument (naming what is wrong) for an empty chain, mismatched sizes, roughness out of order, an empty
// irradiance cube or DFG table, bad options or an unknown colour space, display or view.
std::string render_preview(const std::vector<Cubemap>& chain, const std::vector<double>& roughness,
                           const Cubemap& irradiance, const DfgTable& dfg, const std::string& color_space,
                           const PreviewOptions& options = {});

// The same for the chain as prefilter_specular returns it (each level's own roughness).
std::string render_preview(const std::vector<PrefilteredLevel>& chain, const Cubemap& irradiance, const DfgTable& dfg,
                           const std::string& color_space, const PreviewOptions& options = {});

}  // namespace kiln::envmap
