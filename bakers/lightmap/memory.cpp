#include "bakers/lightmap/memory.h"

#include <cstdio>

#include "bakers/lightmap/lightmap_image.h"

namespace kiln::lightmap {

LightmapMemory lightmap_memory(const LightmapTexels& texels, const BakeStateBytes& bake) {
  return lightmap_memory(texels.texel_count(), texels.samples.size(), texels.valid_count(), bake);
}

LightmapMemory lightmap_memory(size_t texels, size_t samples, size_t valid, const BakeStateBytes& bake) {
  LightmapMemory m;
  m.bytes_per_sample = sizeof(TexelSample);
  m.bytes_per_texel = sizeof(uint32_t) + LightmapImage::kBytesPerTexel + bake.per_texel;
  m.bytes_per_triangle = 0;
  m.peak_bytes_per_triangle = raster_bytes_per_triangle();
  m.peak_bytes_per_sample = raster_bytes_per_fragment() + sizeof(TexelSample);
  m.samples_per_valid_texel = valid > 0 ? static_cast<double>(samples) / valid : 0.0;
  m.total_bytes = texels * m.bytes_per_texel + samples * m.bytes_per_sample;
  return m;
}

std::string LightmapMemory::describe() const {
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "%zu B per texel + %zu B per sample (%.2f samples per valid texel), %zu B per triangle; "
                "%.1f MiB held; while rasterizing %zu B per sample and %zu B per triangle",
                bytes_per_texel, bytes_per_sample, samples_per_valid_texel, bytes_per_triangle,
                total_bytes / (1024.0 * 1024.0), peak_bytes_per_sample, peak_bytes_per_triangle);
  return buf;
}

}  // namespace kiln::lightmap
