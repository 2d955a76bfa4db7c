#include "bakers/lightmap/memory_estimate.h"

#include <algorithm>
#include <cstdio>

#include "bakers/lightmap/leaks.h"
#include "bakers/lightmap/lightmap_image.h"
#include "bakers/lightmap/lightmap_state.h"
#include "bakers/lightmap/texels.h"
#include "bakers/math/rgb.h"
#include "bakers/scene/scene.h"

namespace kiln::lightmap {
namespace {

// The 2 × 2 stratified pattern gives a texel 4 points; texels on a chart's edges get a point from each triangle that
// covers them, so a fifth on average is a generous allowance for meshes of small triangles.
constexpr double kSamplesPerTexel = 5;

// The tracer per triangle at its peak, while Embree builds the BVH (RTC_BUILD_QUALITY_HIGH, spatial splits): measured
// on a 359 400-triangle sphere (memory_estimate_test.cpp), the tracer holds 224 bytes a triangle once built (BVH,
// float vertex and index buffers, its own records), and the bake peaked at 840 to 1 070 bytes a triangle in all over
// several runs, the builder's temporaries making most of the difference.
constexpr double kTracerPerTriangle = 1000;

// A decoded mesh holds its vertices in double: about twice the bytes of the float blob; the bake holds the input,
// a copy it cleans and the cleaned scene while the scene is checked.
constexpr double kMeshCopies = 3 * 2;

// A texture decodes to an Rgb (three doubles) a texel; an 8-bit image compresses to about a byte a texel.
constexpr double kDecodedBytesPerEncodedByte = sizeof(Rgb);

// An output image: the float image and its encoded file (ZIP'd EXR, at most about the raw size), per channel.
constexpr double kOutputBytesPerChannel = 2 * sizeof(float);

double output_channels(const LightmapJobSize& job) {
  double c = 3 + 1 + 1;         // irradiance, validity, error
  if (job.preview) c += 3 + 1;  // the dilated irradiance again, and the PNG's bytes
  if (job.radiance) c += 3;
  if (job.ao) c += 3;
  if (job.directional) c += 12;
  // The denoiser: its output, and per texel the mean, variance and guides it reads (about 15 doubles).
  if (job.denoise) c += 3 + 15 * sizeof(double) / kOutputBytesPerChannel;
  return c;
}

}  // namespace

LightmapMemoryEstimate estimate_memory(const LightmapJobSize& job) {
  LightmapMemoryEstimate e;
  // With light tracing's sums and terms: the plan may trace light, which the spec does not say.
  const BakeStateBytes state = lightmap_state_bytes(job.ao, job.directional, /*traced=*/true);
  const double per_sample = sizeof(TexelSample) + state.per_sample;
  const double per_texel_held =
      sizeof(uint32_t) + LightmapImage::kBytesPerTexel + state.per_texel + kSamplesPerTexel * per_sample;
  const double per_texel_outputs = output_channels(job) * kOutputBytesPerChannel;
  // The set-up's transient for one lightmap at a time: the fragments, twice while sorted, or the leak results.
  const double per_texel_transient =
      kSamplesPerTexel * std::max<double>(2.0 * raster_bytes_per_fragment(), sizeof(LeakResult) + 1);
  e.bytes_per_texel = per_texel_held + per_texel_outputs;
  uint64_t largest = 0;
  for (uint64_t texels : job.lightmap_texels) {
    e.lightmap_bytes.push_back(static_cast<uint64_t>(e.bytes_per_texel * static_cast<double>(texels)));
    largest = std::max(largest, texels);
  }
  // While a lightmap is rasterized, each covering triangle also has a world-space copy.
  e.bytes_per_triangle = kTracerPerTriangle + static_cast<double>(raster_bytes_per_triangle());
  e.scene_bytes = static_cast<uint64_t>(e.bytes_per_triangle * static_cast<double>(job.traced_triangles) +
                                        kMeshCopies * static_cast<double>(job.mesh_blob_bytes));
  const double encoded = static_cast<double>(job.texture_blob_bytes + job.environment_blob_bytes);
  e.input_bytes =
      static_cast<uint64_t>(static_cast<double>(job.mesh_blob_bytes) + encoded + kDecodedBytesPerEncodedByte * encoded);
  e.total = e.scene_bytes + e.input_bytes + static_cast<uint64_t>(per_texel_transient * static_cast<double>(largest));
  for (uint64_t b : e.lightmap_bytes) e.total += b;
  return e;
}

std::string format_bytes(uint64_t bytes) {
  char buf[64];
  const double b = static_cast<double>(bytes);
  if (b >= 1024.0 * 1024 * 1024) {
    std::snprintf(buf, sizeof buf, "%.2f GiB", b / (1024.0 * 1024 * 1024));
  } else if (b >= 1024.0 * 1024) {
    std::snprintf(buf, sizeof buf, "%.1f MiB", b / (1024.0 * 1024));
  } else {
    std::snprintf(buf, sizeof buf, "%llu bytes", static_cast<unsigned long long>(bytes));
  }
  return buf;
}

}  // namespace kiln::lightmap
