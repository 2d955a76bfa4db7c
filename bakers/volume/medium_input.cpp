#include "bakers/volume/medium_input.h"

#include <map>

#include "bakers/bake/invalid_input.h"

namespace kiln::volume {

namespace {

// The media's constructors name their spec's members; the protocol's Medium names some of them otherwise.
bake::InvalidInput as_protocol_field(const bake::InvalidInput& e) {
  static const std::map<std::string, std::string> kRenamed = {{"Le", "emission"},
                                                              {"Le_scale", "emission"},
                                                              {"to_world", "vdb.transform"},
                                                              {"density", "vdb.density_grid"},
                                                              {"emission", "vdb.emission_grid"}};
  const auto it = kRenamed.find(e.field());
  return it == kRenamed.end() ? e : bake::InvalidInput(it->second, e.problem());
}

}  // namespace

std::unique_ptr<Medium> make_medium(const MediumInput& input) {
  try {
    if (const auto* h = std::get_if<HomogeneousMediumSpec>(&input.spec)) return std::make_unique<HomogeneousMedium>(*h);
    return std::make_unique<GridMedium>(std::get<GridMediumSpec>(input.spec));
  } catch (const bake::InvalidInput& e) {
    throw as_protocol_field(e);
  }
}

std::vector<std::unique_ptr<Medium>> make_media(const std::vector<MediumInput>& inputs) {
  std::vector<std::unique_ptr<Medium>> media;
  for (size_t i = 0; i < inputs.size(); ++i) {
    try {
      media.push_back(make_medium(inputs[i]));
    } catch (const bake::InvalidInput& e) {
      throw e.under("media[" + std::to_string(i) + "]");
    }
  }
  return media;
}

}  // namespace kiln::volume
