// What the lightmap planner reads of a scene's participating media (docs/MEDIA.md, "The plan"): which media cannot
// touch the scene (skipped, with the reason), how much of the light along typical light paths the others take away
// (1 − mean transmittance over sampled paths, by ratio tracking), how much of what they take they scatter (the
// single-scattering albedo), and whether they emit.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "bakers/scene/scene.h"
#include "bakers/volume/medium.h"
#include "bakers/volume/medium_input.h"

namespace kiln::plan {

struct MediaAnalysis {
  std::vector<std::string> skipped;           // "media[I] 'NAME': its bounds ... do not overlap the scene's ..."
  std::vector<const volume::Medium*> active;  // the media that can touch the scene, in input order
  std::vector<int> active_index;              // their indices in the input
  int paths = 0;                              // light paths sampled
  double extinction = 0;                      // 1 − the mean transmittance along them, in the channel that loses most
  double extinction_error = 0;                // the standard error of that mean
  double albedo = 0;                          // max over the active media and channels of sigma_s / (sigma_a + sigma_s)
  bool emissive = false;                      // some active medium emits
};

// Light paths: from points uniform in the scene's box, one to each light with a position (or along a directional
// light, or towards a random direction of the sky), and one to another such point (light between surfaces);
// `paths` of them, with a fixed seed. `media` are built from `inputs` (the same order).
MediaAnalysis analyse_media(const scene::Scene& scene, const std::vector<volume::MediumInput>& inputs,
                            const std::vector<const volume::Medium*>& media, int paths = 512);

}  // namespace kiln::plan
