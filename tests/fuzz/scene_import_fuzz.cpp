// The client's scene import (client/import/scene_import.cpp, through Assimp) of a damaged model: the first byte
// picks the file type (glTF, GLB, OBJ, FBX), the rest is the file, written to a private temporary directory since
// the importer reads a path. Every failure must be std::runtime_error with a message, never a crash.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "client/import/scene_import.h"

namespace {

// A directory of this process's own, removed at exit.
struct Scratch {
  std::filesystem::path dir;
  Scratch() {
    std::string templ = (std::filesystem::temp_directory_path() / "kiln-fuzz-import-XXXXXX").string();
    if (!mkdtemp(templ.data())) throw std::runtime_error("scene_import_fuzz: cannot create a temporary directory");
    dir = templ;
  }
  ~Scratch() {
    std::error_code ignored;
    std::filesystem::remove_all(dir, ignored);
  }
};

const std::filesystem::path& scratch() {
  static const Scratch s;
  return s.dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  static const char* const kExtensions[] = {".gltf", ".glb", ".obj", ".fbx"};
  const std::filesystem::path path = scratch() / (std::string("model") + kExtensions[data[0] % 4]);
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data) + 1, static_cast<std::streamsize>(size - 1));
  }
  try {
    kiln::client::import_scene(path.string());
  } catch (const std::runtime_error& e) {
    // For checking a corpus by hand: which inputs are refused, and why.
    if (std::getenv("KILN_FUZZ_VERBOSE")) std::fprintf(stderr, "refused: %s\n", e.what());
  }
  std::filesystem::remove(path);
  return 0;
}
