// An edge-avoiding à-trous wavelet filter for lightmaps (Dammertz et al. 2010, "Edge-avoiding À-Trous wavelet
// transform for fast global illumination filtering"), its luminance term scaled by each texel's estimated variance as
// in SVGF (Schied et al. 2017, "Spatiotemporal variance-guided filtering"). Plain arrays in, plain arrays out: the
// guides come from the bake (texel_guides.h), the filter knows nothing of scenes.
//
// Level i (i = 0 … levels − 1) convolves with the 5 × 5 B3-spline kernel h = (1, 4, 6, 4, 1)/16 ⊗ the same, its taps
// 2^i texels apart. A tap q of texel p weighs h(q) · w_l · w_n · w_x · w_c:
//   w_l = exp(−|Y_p − Y_q| / (σ_l √Var_p + ε_p))   luminance, Var_p the variance of p's mean (ε_p = 1e-9 Y_p + tiny,
//                                                   so that an exact texel, Var_p = 0, keeps only taps equal to it);
//   w_n = max(0, n_p · n_q)^σ_n                     shading normal;
//   w_x = exp(−|n_p · (x_q − x_p)| / (σ_x s_p))      world position: q's distance from p's tangent plane in texels
//                                                   of p (s_p, world size): 0 on a flat chart at any step; steps
//                                                   in the geometry and points moved off the surface stop it;
//   w_c = 1 for a valid tap of p's chart, else 0    hard: nothing crosses a chart border or reads an invalid texel.
// Colour and variance are filtered together: c' = Σ w c / Σ w and Var' = Σ w² Var / (Σ w)², so that the luminance
// term tightens from level to level as the noise falls.
//
// Each level moves a texel's luminance by at most 2.25 a, a = σ_l √Var_p + ε_p (a tap adds at most h(q) a/e to the
// weighted sum of differences, since x e^(−x/a) ≤ a/e; Σ_q≠p h(q) ≤ 55/64 and Σ w ≥ h(p) = 9/64): an exact texel stays
// where it is, and no texel moves far beyond its own noise.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "bakers/math/rgb.h"
#include "bakers/math/vec3.h"

namespace kiln::lightmap {

// What the filter knows of each texel beside its colour, row-major (top row first), width · height entries each.
struct TexelGuides {
  int width = 0, height = 0;
  std::vector<uint8_t> valid;      // non-zero: the texel has sample points
  std::vector<Vec3> position;      // world space
  std::vector<Vec3> normal;        // world space, unit
  std::vector<double> texel_size;  // world length of a texel's edge, > 0
  std::vector<uint32_t> chart;     // texels of different charts never mix
};

struct DenoiseOptions {
  int levels = 5;                // steps 1, 2, 4, 8, 16 texels; [0, 12]
  double sigma_luminance = 4.0;  // σ_l, SVGF's value; > 0
  double sigma_normal = 128.0;   // σ_n, SVGF's value; ≥ 0
  double sigma_position = 1.0;   // σ_x, in texel sizes; > 0
};

struct DenoiseResult {
  std::vector<Rgb> colour;
  std::vector<double> variance;  // of the filtered luminance, under SVGF's independence assumption
};

// Filters `colour` (e.g. irradiance, W·m⁻²) with `variance` (of each texel's mean luminance, in the colour's units
// squared). Invalid texels come out black with variance 0 and are never read. A valid texel whose colour, variance or
// guides are not usable (a colour outside the float range, a variance or texel size that is negative or not finite,
// a guide that is not finite) is neither filtered nor read: it keeps its colour (black if not finite) and its
// variance (+∞ if not a variance). Every colour returned is finite. Throws
// std::invalid_argument when a size disagrees with width · height or an option is out of range.
DenoiseResult denoise(const std::vector<Rgb>& colour, const std::vector<double>& variance, const TexelGuides& guides,
                      const DenoiseOptions& options = {});

// One line for people and metadata: the filter and its settings.
std::string describe(const DenoiseOptions& options);

}  // namespace kiln::lightmap
