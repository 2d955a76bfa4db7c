// The KILNMSH1 mesh decoder (daemon/mesh_blob_decode.cpp): any bytes an uploader stores as a mesh blob.
#include <cstddef>
#include <cstdint>
#include <string>

#include "daemon/mesh_blob_decode.h"
#include "daemon/translate.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    kiln::daemon::decode_mesh_blob(std::string(reinterpret_cast<const char*>(data), size), "job.lightmap.meshes[0]",
                                   "mesh");
  } catch (const kiln::daemon::InvalidField&) {
  }
  return 0;
}
