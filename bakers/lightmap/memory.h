// What the texel layer of a lightmap costs in memory, per texel, per sample and per triangle, for the bake report.
#pragma once

#include <cstddef>
#include <string>

#include "bakers/lightmap/texels.h"

namespace kiln::lightmap {

// What a bake keeps beside the texel layer for the whole bake (lightmap_bake.cpp knows it): per texel, its attempt
// count and the AO and SH sums when those outputs are asked for. Per sample it keeps nothing beyond the sample.
struct BakeStateBytes {
  size_t per_texel = 0;
};

struct LightmapMemory {
  size_t bytes_per_sample = 0;         // one TexelSample
  size_t bytes_per_texel = 0;          // every texel, valid or not: the sample offset, the LightmapImage's
                                       // accumulators (sum, luminance square sum, count, validity) and the bake's
                                       // state per texel
  size_t bytes_per_triangle = 0;       // held by the texel layer per triangle after rasterization: none (samples
                                       // refer to the scene's arrays; the tracer states its own per-triangle cost)
  size_t peak_bytes_per_triangle = 0;  // while rasterizing: world vertices and normals of each covering triangle
  size_t peak_bytes_per_sample = 0;    // while rasterizing: the fragment and the sample
  double samples_per_valid_texel = 0;
  size_t total_bytes = 0;        // held after rasterization: texels × bytes_per_texel + samples × per sample
  std::string describe() const;  // one line for people
};

LightmapMemory lightmap_memory(const LightmapTexels& texels, const BakeStateBytes& bake = {});
// The same figures for `texels` texels holding `samples` sample points, `valid` of the texels valid.
LightmapMemory lightmap_memory(size_t texels, size_t samples, size_t valid, const BakeStateBytes& bake = {});

}  // namespace kiln::lightmap
