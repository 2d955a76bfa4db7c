// The kiln mesh layout (proto/kiln.proto, "Lightmap jobs"): one blob per mesh, written by the client's importers and
// read by the daemon's translation layer. Plain arrays in, bytes out.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace kiln::client {

struct MeshArrays {
  std::vector<std::array<float, 3>> positions;
  std::vector<std::array<float, 3>> normals;      // empty or one per position
  std::vector<std::array<float, 2>> uv;           // empty or one per position (texture UVs, v = 0 at the top)
  std::vector<std::array<float, 2>> lightmap_uv;  // empty or one per position
  std::vector<uint32_t> indices;                  // three per triangle
  std::vector<uint32_t> materials;                // empty or one per triangle
};

// Throws std::invalid_argument if an optional array's length does not match, indices are not a multiple of three
// or the counts exceed the layout's bounds (2^24 vertices or triangles).
std::string encode_mesh_blob(const MeshArrays& mesh);

}  // namespace kiln::client
