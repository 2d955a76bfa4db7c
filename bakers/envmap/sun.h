// The sun as an explicit light: the few texels of an environment that are far brighter than the rest are taken out
// of the map that the prefilter samples (what is left is the "sky") and added back exactly, texel by texel, to every
// output. A region thousands of times brighter than the sky would otherwise make fireflies (a sample that hits it
// outweighs all others) or blotches (filtered importance sampling smears it over a mip texel).
//
// ## The rule (documented once; the report repeats it)
// Luminance Y = 0.2126 R + 0.7152 G + 0.0722 B (Rec. 709 weights, the working space's primaries). Q is the
// solid-angle-weighted 90th percentile of Y over the sphere ("the bright end of the sky": 90 % of the sphere is no
// brighter). A texel is a sun texel when Y > T = kSunContrast · Q (32: a clear sky's own range, horizon to zenith and
// clouds, stays well below; the sun is 10^4–10^5 times the sky). At most kMaxSunTexels texels (the brightest) are
// taken, which bounds the cost of the exact sums (sun texels × output texels). In automatic mode the sun is used when
// its texels hold at least kMinSunPowerFraction of the map's power (∫ Y dω); forced on, whenever a texel exceeds T;
// forced off, never (the sun stays in the sampled map).
//
// ## The split (exact: sky + sun = source, per texel and channel)
// A sun texel's sky value is filled in from its non-sun neighbours (8-neighbourhood across cube edges, peeled from the
// border of the sun inwards), per channel no larger than the texel itself; the sun keeps the rest, L − sky ≥ 0. So
// the sky has no hole and no spike, and nothing is lost.
//
// ## Exact contributions of the sun texels (point texels at their centres, exact solid angles Ω_j)
//   specular, level with lobe D(h)(n·l) and W = ∫ D(h)(n·l) dω (lobe.h):  Σ_j L_j D(h_j)(n·l_j) Ω_j / W
//   irradiance:                                                          Σ_j L_j max(0, n·l_j) Ω_j
// the same terms brute_force_prefilter and irradiance_at sum for those texels, with the prefilter's normalisation.
#pragma once

#include <string>
#include <vector>

#include "bakers/envmap/cubemap.h"
#include "bakers/envmap/lobe.h"
#include "bakers/envmap/sh.h"

namespace kiln::envmap {

inline constexpr double kSunContrast = 32.0;
inline constexpr double kSunQuantile = 0.9;
inline constexpr int kMaxSunTexels = 1024;
inline constexpr double kMinSunPowerFraction = 1e-3;

enum class SunMode { automatic, forced_on, forced_off };

struct SunTexel {
  int face = 0, x = 0, y = 0;  // in the source cube
  Vec3 dir;                    // unit direction of the texel centre
  double solid_angle = 0;      // exact
  Rgb radiance;                // the part of the texel's radiance moved out of the sky
};

struct SunSplit {
  Cubemap sky;                    // the source minus the sun
  std::vector<SunTexel> sun;      // empty: no sun (sky is the source)
  double quantile_luminance = 0;  // Q
  double threshold = 0;           // T = kSunContrast · Q
  int candidates = 0;             // texels with Y > T (before the kMaxSunTexels cap)
  double power_fraction = 0;      // of the sun texels' luminance power in the whole map's (before the split)
  bool enabled = false;           // the sun is used
  std::string reason;             // why, in words
};

// Splits `source` by the rule above.
SunSplit split_sun(const Cubemap& source, SunMode mode = SunMode::automatic);

// Σ_j L_j D(h_j)(n·l_j) Ω_j / W at unit n.
Rgb sun_specular_at(const std::vector<SunTexel>& sun, const SplitSumLobe& lobe, double normalization, const Vec3& n);
// Adds it to every texel of `out` (in parallel).
void add_sun_specular(Cubemap& out, const std::vector<SunTexel>& sun, const SplitSumLobe& lobe, double normalization);
// Σ_j L_j max(0, n·l_j) Ω_j at unit n, and added to every texel of `out` (in parallel).
Rgb sun_irradiance_at(const std::vector<SunTexel>& sun, const Vec3& n);
void add_sun_irradiance(Cubemap& out, const std::vector<SunTexel>& sun);
// Deposits the sun back into a cube of any size: each sun texel's power L_j Ω_j into the texel containing its
// direction (divided by that texel's solid angle). With the source's own size this restores the source exactly.
void deposit_sun(Cubemap& out, const std::vector<SunTexel>& sun);

// The diffuse outputs of a split: the irradiance cube of the sky (downsampled with downsample_2x while larger than
// max_source_size: the cosine lobe needs no more) plus the sun's exact irradiance; and the SH radiance coefficients
// of the sky at full size plus each sun texel's exact projection L_j Y_i(l_j) Ω_j (= project_sh of sky + sun).
Cubemap irradiance_with_sun(const Cubemap& sky, const std::vector<SunTexel>& sun, int out_size, int max_source_size);
ShCoefficients project_sh_with_sun(const Cubemap& sky, const std::vector<SunTexel>& sun);

}  // namespace kiln::envmap
