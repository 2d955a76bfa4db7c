// A medium as a bake's input gives it (LightmapBakeInput::media), before it is built: a homogeneous box or fog, or a
// density grid read from a VDB blob. The daemon fills it from LightmapJob.media; the grids are read from the blob by
// the daemon's input loading (read_vdb), so that the bake holds only what it will track.
#pragma once

#include <memory>
#include <string>
#include <variant>
#include <vector>

#include "bakers/volume/grid_medium.h"
#include "bakers/volume/homogeneous_medium.h"

namespace kiln::volume {

struct MediumInput {
  std::string name;  // for people and the report
  std::variant<HomogeneousMediumSpec, GridMediumSpec> spec;
  // Grid media: the grids read from the blob into spec's density and emission (emission_grid empty: none).
  std::string density_grid = "density";
  std::string emission_grid{};
};

// Builds the medium. Throws bake::InvalidInput naming the field as the protocol's Medium does ("sigma_a", "g",
// "emission", "box", "vdb.transform", "vdb.density_grid") for a value out of range, a singular placement or a grid
// not loaded.
std::unique_ptr<Medium> make_medium(const MediumInput& input);

// Every medium of `inputs`, in order; the fields of a problem are under "media[I]".
std::vector<std::unique_ptr<Medium>> make_media(const std::vector<MediumInput>& inputs);

}  // namespace kiln::volume
