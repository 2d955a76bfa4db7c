#include "daemon/mesh_blob_decode.h"

#include <cstring>
#include <vector>

#include "daemon/translate.h"

namespace kiln::daemon {

scene::Mesh decode_mesh_blob(const std::string& bytes, const std::string& field, const std::string& name) {
  constexpr size_t kHeader = 8 + 3 * 4;
  constexpr uint32_t kMaxCount = kMaxMeshBlobCount;
  if (bytes.size() < kHeader || bytes.compare(0, 8, "KILNMSH1") != 0) {
    throw InvalidField(field,
                       "not a kiln mesh blob (it must start with \"KILNMSH1\"; the client's importer writes "
                       "them)");
  }
  uint32_t header[3];
  std::memcpy(header, bytes.data() + 8, sizeof header);
  const uint32_t v = header[0], t = header[1], flags = header[2];
  if (v > kMaxCount || t > kMaxCount) {
    throw InvalidField(field, "mesh of " + std::to_string(v) + " vertices and " + std::to_string(t) +
                                  " triangles: at most 16777216 of each");
  }
  if (flags & ~0xFu)
    throw InvalidField(field, "unknown flags " + std::to_string(flags) + " (only bits 0-3 are defined)");
  const bool normals = flags & 1u, uv = flags & 2u, lightmap_uv = flags & 4u, materials = flags & 8u;
  const uint64_t expected = kHeader + uint64_t{4} * (3ull * v + (normals ? 3ull * v : 0) + (uv ? 2ull * v : 0) +
                                                     (lightmap_uv ? 2ull * v : 0) + 3ull * t + (materials ? t : 0));
  if (bytes.size() != expected) {
    throw InvalidField(field, "mesh blob of " + std::to_string(bytes.size()) + " bytes, but its header (" +
                                  std::to_string(v) + " vertices, " + std::to_string(t) + " triangles, flags " +
                                  std::to_string(flags) + ") needs " + std::to_string(expected));
  }
  const char* at = bytes.data() + kHeader;
  // memcpy needs non-null pointers even for 0 bytes, and an empty vector's data() may be null (a mesh of 0
  // vertices or 0 triangles decodes to empty arrays).
  auto copy = [&](void* into, size_t bytes) {
    if (bytes > 0) std::memcpy(into, at, bytes);
    at += bytes;
  };
  auto floats = [&](size_t n) {
    std::vector<float> out(n);
    copy(out.data(), n * 4);
    return out;
  };
  scene::Mesh m;
  m.name = name;
  const std::vector<float> p = floats(3ull * v);
  m.positions.reserve(v);
  for (uint32_t i = 0; i < v; ++i) m.positions.push_back({p[3 * i], p[3 * i + 1], p[3 * i + 2]});
  if (normals) {
    const std::vector<float> n = floats(3ull * v);
    for (uint32_t i = 0; i < v; ++i) m.normals.push_back({n[3 * i], n[3 * i + 1], n[3 * i + 2]});
  }
  auto uvs = [&](std::vector<Point2>& into) {
    const std::vector<float> a = floats(2ull * v);
    for (uint32_t i = 0; i < v; ++i) into.push_back({a[2 * i], a[2 * i + 1]});
  };
  if (uv) uvs(m.uv);
  if (lightmap_uv) uvs(m.lightmap_uv);
  m.indices.resize(3ull * t);
  copy(m.indices.data(), m.indices.size() * 4);
  if (materials) {
    m.material.resize(t);
    copy(m.material.data(), m.material.size() * 4);
  }
  // Indices out of range, NaN positions and the like are the scene check's to report, per triangle: the mesh
  // still bakes what it can.
  return m;
}

}  // namespace kiln::daemon
