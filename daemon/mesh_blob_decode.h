// The kiln mesh layout (proto/kiln.proto, "Lightmap jobs") read back into a scene mesh. The daemon decodes mesh blobs
// in the worker (translate.cpp's load_inputs), never on a connection's thread.
#pragma once

#include <string>

#include "bakers/scene/scene.h"

namespace kiln::daemon {

// The most vertices, and the most triangles, one mesh blob may hold.
inline constexpr uint32_t kMaxMeshBlobCount = 1u << 24;

// Decodes `bytes` into a mesh named `name`. Throws InvalidField naming `field` for a blob that is not in the layout:
// a wrong magic, unknown flag bits, counts beyond kMaxMeshBlobCount, or a size other than the header implies
// (truncated or with trailing bytes). Out-of-range indices and NaN positions decode as they are: the bake's scene
// check reports them per triangle and bakes what it can.
scene::Mesh decode_mesh_blob(const std::string& bytes, const std::string& field, const std::string& name);

}  // namespace kiln::daemon
