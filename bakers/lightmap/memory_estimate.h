// What a lightmap bake will hold at its peak, estimated before anything is decoded or allocated, from what a job
// spec says: the texels of each lightmap, the triangles traced, the bytes of the input blobs and the outputs asked
// for. The daemon refuses a job whose estimate exceeds its memory limit, and runs jobs together only while the sum of
// their estimates fits (so a job that fits is never killed by the kernel for memory).
//
// The model, every figure from the sizes of the structures the bake allocates (memory_estimate.cpp):
//  - per texel of each lightmap (every texel counted, as if the charts covered the whole map; with atlas pages, each
//    of max_pages pages of page_size² texels, since how many the packer fills is not known before the bake): its
//    sample points
//    (samples_per_texel of them) and the bake's state, held to the end; while that lightmap is rasterized and probed
//    for leaks, the fragments (twice, while sorted) and the leak results; and its output images, raw and encoded,
//    which the bake holds until it returns.
//  - per traced triangle: Embree's BVH, vertex and index buffers and the tracer's own records, at the peak of the
//    BVH build, and a world-space copy while the triangle is rasterized.
//  - the input blobs as bytes, the meshes decoded (in double precision, in up to three copies while the scene is
//    checked) and the textures decoded at 24 bytes a texel, their texel count taken as the encoded size (an 8-bit
//    image compresses to about a byte a texel). That last term is an estimate, not a bound: an image that compresses
//    far better than that decodes to more.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace kiln::lightmap {

struct LightmapJobSize {
  std::vector<uint64_t> lightmap_texels;  // per lightmap: width × height
  uint64_t traced_triangles = 0;          // over the instances, each its mesh's triangles (an upper bound will do)
  uint64_t mesh_blob_bytes = 0;           // the meshes as uploaded (KILNMSH1), summed over meshes (not instances)
  uint64_t texture_blob_bytes = 0;        // the encoded textures
  uint64_t environment_blob_bytes = 0;    // the encoded environment image
  bool ao = false, directional = false, radiance = false, denoise = false, preview = true;
};

struct LightmapMemoryEstimate {
  std::vector<uint64_t> lightmap_bytes;  // per lightmap, in the order given: what its texels cost
  uint64_t scene_bytes = 0;              // the meshes decoded and the tracer
  uint64_t input_bytes = 0;              // the blobs and the decoded textures and environment
  uint64_t total = 0;                    // the peak: the sum of the above and the largest set-up transient
  double bytes_per_texel = 0;            // of a lightmap, with the outputs asked for
  double bytes_per_triangle = 0;         // traced
};

LightmapMemoryEstimate estimate_memory(const LightmapJobSize& job);

// "1.5 GiB" and the like, for messages.
std::string format_bytes(uint64_t bytes);

}  // namespace kiln::lightmap
