// What the texel layer of a lightmap costs in memory, for the bake report (issue 5: "memory per texel and per
// triangle stated").
#pragma once

#include <cstddef>
#include <string>

#include "bakers/lightmap/texels.h"

namespace kiln::lightmap {

struct LightmapMemory {
  size_t bytes_per_sample = 0;       // one TexelSample
  size_t bytes_per_texel = 0;        // every texel, valid or not: the sample offset and the LightmapImage's
                                     // accumulators (sum, luminance square sum, count, validity)
  size_t bytes_per_triangle = 0;     // held by the texel layer per triangle after rasterization: none (samples
                                     // refer to the scene's arrays; the tracer states its own per-triangle cost)
  size_t peak_bytes_per_triangle = 0;  // while rasterizing: world vertices and normals of each covering triangle
  size_t peak_bytes_per_sample = 0;    // while rasterizing: the fragment, twice (blocks and sorted), and the sample
  double samples_per_valid_texel = 0;
  size_t total_bytes = 0;            // held after rasterization: texels × bytes_per_texel + samples × per sample
  std::string describe() const;      // one line for people
};

LightmapMemory lightmap_memory(const LightmapTexels& texels);

}  // namespace kiln::lightmap
