// The per-lightmap outputs beside the irradiance, validity and error images (lightmap_image.h): the denoised
// irradiance, the diffuse radiance ρE/π, ambient occlusion, order-1 SH of incoming radiance, and the preview PNG. File
// names, channels and metadata as listed in lightmap_bake.h. They are made from a page's results
// (lightmap_results.h), which collect_results fills from the sampling state, a tile or the whole page at a time.
#pragma once

#include <string>
#include <vector>

#include "bakers/bake/output.h"
#include "bakers/lightmap/denoise.h"
#include "bakers/lightmap/integrator.h"
#include "bakers/lightmap/lightmap_results.h"
#include "bakers/lightmap/lightmap_state.h"
#include "bakers/lightmap/texel_guides.h"
#include "bakers/scene/scene.h"

namespace kiln::lightmap {

// What collect_results needs beside the state: the scene the texels were rasterized from and its shading materials
// (for the radiance's reflectance), and the page's chart numbering (for the denoiser's guides), shared by its tiles.
struct ResultsContext {
  const scene::Scene* scene = nullptr;
  const std::vector<ShadingMaterial>* materials = nullptr;
  ChartIds* charts = nullptr;  // needed when out.channels().guides
};

// Copies the results of `m`, whose texel (0, 0) is texel (x0, y0) of the page `out` (0, 0 for a whole page), into
// `out`: each texel's mean, error and count, and the channels `out` keeps.
void collect_results(const LightmapState& m, int x0, int y0, const ResultsContext& context, LightmapResults& out);

// Copies the results of a tile that was not sampled, whose texels (rasterized, leaks resolved) are `texels`, as
// collect_results would from a state made of them with no estimate added: each valid texel black with an unknown
// (+∞) error and no count, and its guides; without making that state, whose image alone is 120 bytes a texel.
void collect_unsampled(const LightmapTexels& texels, int x0, int y0, const ResultsContext& context,
                       LightmapResults& out);

// The results of a whole page's state.
LightmapResults collect_results(const LightmapState& m, const ResultChannels& channels, const ResultsContext& context);

// NAME_irradiance_denoised.exr: the irradiance through the denoiser (denoise.h), guided by the page's guides, each
// texel's variance (its standard error squared); dilated by `padding` texels (polling `stop`), then `finish`ed
// (seams.h), with NAME_irradiance.exr's metadata and a kiln:content naming the filter.
bake::BakeOutput denoised_output(const LightmapResults& r, const DenoiseOptions& options, int padding,
                                 const std::string& color_space, const bake::StopCheck& stop = {},
                                 const ImageFinish& finish = {});

// NAME_radiance.exr: the irradiance times the texel's diffuse reflectance, over π; dilated by `padding` texels like
// the irradiance (so that bilinear lookups at a chart's edge read the chart's values, not black), then `finish`ed.
bake::BakeOutput radiance_output(const LightmapResults& r, const std::string& color_space, int padding = 0,
                                 const bake::StopCheck& stop = {}, const ImageFinish& finish = {});

// NAME_ao.exr: the mean AO estimate per texel; `ao_distance` is the distance that counts as unoccluded. Dilated and
// finished as the radiance.
bake::BakeOutput ao_output(const LightmapResults& r, double ao_distance, int padding = 0,
                           const bake::StopCheck& stop = {}, const ImageFinish& finish = {});

// The estimated relative error of the SH over the valid texels that have one: RMS (−1: none) and largest.
struct ShError {
  double rms = -1;
  double max = 0;
};
ShError sh_error(const LightmapResults& r);

// NAME_sh.exr: the mean SH coefficients per texel, with `error` in its metadata.
bake::BakeOutput sh_output(const LightmapResults& r, const ShError& error, const std::string& color_space);

// NAME_preview.png: the irradiance, dilated by `padding` texels and `finish`ed as NAME_irradiance.exr is, through the
// display transform.
bake::BakeOutput preview_output(const LightmapResults& r, int padding, const std::string& color_space,
                                const bake::StopCheck& stop = {}, const ImageFinish& finish = {});

}  // namespace kiln::lightmap
