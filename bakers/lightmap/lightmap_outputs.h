// The per-lightmap outputs beside the irradiance, validity and error images (lightmap_image.h): the denoised
// irradiance, the diffuse radiance ρE/π, ambient occlusion, order-1 SH of incoming radiance, and the preview PNG. File
// names, channels and metadata as listed in lightmap_bake.h.
#pragma once

#include <string>
#include <vector>

#include "bakers/bake/output.h"
#include "bakers/lightmap/denoise.h"
#include "bakers/lightmap/integrator.h"
#include "bakers/lightmap/lightmap_state.h"
#include "bakers/scene/scene.h"

namespace kiln::lightmap {

// NAME_irradiance_denoised.exr: the irradiance through the denoiser (denoise.h), guided by texel_guides(m, scene)
// (`scene` the one the texels were rasterized from), each texel's variance (relative_error · luminance of the mean)²;
// dilated by `padding` texels (polling `stop`), then `finish`ed (seams.h), with NAME_irradiance.exr's metadata and a
// kiln:content naming the filter.
bake::BakeOutput denoised_output(const LightmapState& m, const scene::Scene& scene, const DenoiseOptions& options,
                                 int padding, const std::string& color_space, const bake::StopCheck& stop = {},
                                 const ImageFinish& finish = {});

// NAME_radiance.exr: the irradiance times the texel's diffuse reflectance, over π; dilated by `padding` texels like
// the irradiance (so that bilinear lookups at a chart's edge read the chart's values, not black), then `finish`ed.
bake::BakeOutput radiance_output(const LightmapState& m, const scene::Scene& scene,
                                 const std::vector<ShadingMaterial>& materials, const std::string& color_space,
                                 int padding = 0, const bake::StopCheck& stop = {}, const ImageFinish& finish = {});

// NAME_ao.exr: the mean AO estimate per texel; `ao_distance` is the distance that counts as unoccluded. Dilated and
// finished as the radiance.
bake::BakeOutput ao_output(const LightmapState& m, double ao_distance, int padding = 0,
                           const bake::StopCheck& stop = {}, const ImageFinish& finish = {});

// The estimated relative error of the SH over the valid texels that have one: RMS (−1: none) and largest.
struct ShError {
  double rms = -1;
  double max = 0;
};
ShError sh_error(const LightmapState& m);

// NAME_sh.exr: the mean SH coefficients per texel, with `error` in its metadata.
bake::BakeOutput sh_output(const LightmapState& m, const ShError& error, const std::string& color_space);

// NAME_preview.png: the irradiance, dilated by `padding` texels and `finish`ed as NAME_irradiance.exr is, through the
// display transform.
bake::BakeOutput preview_output(const LightmapState& m, int padding, const std::string& color_space,
                                const bake::StopCheck& stop = {}, const ImageFinish& finish = {});

}  // namespace kiln::lightmap
