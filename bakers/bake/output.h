// One file a bake produces, with what a store or a client needs to know about it.
#pragma once

#include <string>

namespace kiln::bake {

struct BakeOutput {
  std::string name;         // "albedo.exr", "specular.ktx2", "report.json", ...
  std::string media_type;   // "image/x-exr", "application/x-merl-brdf", "application/json", ...
  std::string color_space;  // "scene_linear" for RGB radiometric values, "data" for non-colour numbers, "" for reports
  std::string bytes;
};

}  // namespace kiln::bake
