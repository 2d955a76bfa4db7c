// One lightmap while it bakes: its texels, the image its estimates accumulate into, and the
// per-texel sums of the optional outputs (AO, SH). The bake's stages (lightmap_bake.cpp), the adaptive sampler and
// the outputs all work on it.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "bakers/lightmap/integrator.h"
#include "bakers/lightmap/leaks.h"
#include "bakers/lightmap/lightmap_image.h"
#include "bakers/lightmap/memory.h"
#include "bakers/lightmap/texels.h"
#include "bakers/math/rgb.h"

namespace kiln::lightmap {

struct LightmapState {
  std::string name;
  LightmapTexels texels;
  LightmapImage image;
  LeakReport leaks;
  std::vector<Rgb> ao_sum;                   // per texel, sum over estimates (AO in every channel)
  std::vector<std::array<Rgb, 4>> sh_sum;    // per texel
  std::vector<std::array<double, 4>> sh_y2;  // per texel, sum over estimates of each coefficient's luminance²
  std::vector<uint32_t> attempts;            // per texel, estimates tried (kept or dropped)
  // Per texel, 1 where light tracing brings the indirect light and the texel's own paths gather only direct light
  // (light_tracing.h); empty when light tracing is off.
  std::vector<uint8_t> traced;
  // Where these texels are in their page, for the seeds of their estimates (adaptive_sampler.h), so that a texel
  // draws the same sequences whether its page is baked whole or in tiles: the page's index among the bake's
  // lightmaps, and for a tile its texel (0, 0) in the page and the page's width (0: the state is the whole page).
  uint32_t page = 0;
  int x0 = 0, y0 = 0, page_width = 0;

  // The index in the page of texel t of this state.
  size_t page_texel(size_t t) const {
    if (page_width == 0) return t;
    const size_t w = static_cast<size_t>(image.width());
    return (static_cast<size_t>(y0) + t / w) * static_cast<size_t>(page_width) + static_cast<size_t>(x0) + t % w;
  }
};

// The receiver of a texel sample: its surface with the lift that clears its own float triangle, and its shading
// normal, or the geometric normal where the shading normal faces away from it. Made when a path starts, not held:
// per sample it would be as large again as the sample.
Receiver receiver_of(const TexelSample& sample);

// A lightmap ready to sample: its texels after leak handling, an empty image of its valid texels, and the AO and SH
// sums when those outputs are asked for.
LightmapState make_lightmap_state(std::string name, LightmapTexels texels, const LeakReport& leaks, bool ao,
                                  bool directional);

// What a LightmapState holds beside its texels and image, per texel and per sample, for the report's memory figures;
// `traced`: with light tracing's sums and terms (light_tracing.h).
BakeStateBytes lightmap_state_bytes(bool ao, bool directional, bool traced);

}  // namespace kiln::lightmap
