// An OpenVDB file uploaded as a blob for a medium (bakers/volume/vdb_file.cpp, read_vdb): its size and magic number
// checked, its structure walked (bakers/volume/vdb_structure.cpp: every grid's metadata, transform, topology and
// compressed chunks, node counts), parsed by OpenVDB's stream reader, the named grids checked before kiln makes
// anything from them.
// bake::InvalidInput for bytes that are not such a file.
#include <cstddef>
#include <cstdint>
#include <span>

#include "bakers/bake/invalid_input.h"
#include "bakers/volume/vdb_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    kiln::volume::read_vdb(std::span<const uint8_t>(data, size), {"density", "emission"});
  } catch (const kiln::bake::InvalidInput&) {
  }
  return 0;
}
