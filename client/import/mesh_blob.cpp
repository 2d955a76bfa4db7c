#include "client/import/mesh_blob.h"

#include <cstring>
#include <stdexcept>

namespace kiln::client {
namespace {

constexpr uint32_t kMaxCount = 1u << 24;

template <class T>
void append(std::string& out, const T* data, size_t count) {
  static_assert(sizeof(float) == 4 && sizeof(uint32_t) == 4);
  const size_t at = out.size();
  out.resize(at + count * sizeof(T));
  if (count) std::memcpy(out.data() + at, data, count * sizeof(T));  // little-endian hosts only (x86-64, aarch64)
}

void append_u32(std::string& out, uint32_t v) { append(out, &v, 1); }

}  // namespace

std::string encode_mesh_blob(const MeshArrays& m) {
  const size_t v = m.positions.size(), t = m.indices.size() / 3;
  auto check = [&](size_t n, size_t want, const char* what) {
    if (n != 0 && n != want) {
      throw std::invalid_argument(std::string("mesh ") + what + ": " + std::to_string(n) + " entries for " +
                                  std::to_string(want) + " expected");
    }
  };
  check(m.normals.size(), v, "normals");
  check(m.uv.size(), v, "texture UVs");
  check(m.lightmap_uv.size(), v, "lightmap UVs");
  check(m.materials.size(), t, "material indices");
  if (m.indices.size() % 3 != 0) throw std::invalid_argument("mesh indices: not a multiple of three");
  if (v > kMaxCount || t > kMaxCount) {
    throw std::invalid_argument("mesh too large: " + std::to_string(v) + " vertices, " + std::to_string(t) +
                                " triangles (at most 16777216 each; split the mesh)");
  }
  uint32_t flags = 0;
  if (!m.normals.empty()) flags |= 1u;
  if (!m.uv.empty()) flags |= 2u;
  if (!m.lightmap_uv.empty()) flags |= 4u;
  if (!m.materials.empty()) flags |= 8u;
  std::string out = "KILNMSH1";
  append_u32(out, static_cast<uint32_t>(v));
  append_u32(out, static_cast<uint32_t>(t));
  append_u32(out, flags);
  append(out, m.positions.data(), v);
  append(out, m.normals.data(), m.normals.size());
  append(out, m.uv.data(), m.uv.size());
  append(out, m.lightmap_uv.data(), m.lightmap_uv.size());
  append(out, m.indices.data(), m.indices.size());
  append(out, m.materials.data(), m.materials.size());
  return out;
}

}  // namespace kiln::client
