#include "bakers/lightmap/media_report.h"

#include <algorithm>

#include <nlohmann/json.hpp>

namespace kiln::lightmap {
namespace {

using Json = nlohmann::ordered_json;

// One medium: its kind and the voxels its grids had replaced.
Json medium_json(const volume::MediumInput& m) {
  Json j = {{"name", m.name}};
  if (const auto* h = std::get_if<volume::HomogeneousMediumSpec>(&m.spec)) {
    j["kind"] = h->box ? "box" : "fog";
    return j;
  }
  const auto& g = std::get<volume::GridMediumSpec>(m.spec);
  j["kind"] = "vdb";
  int64_t non_finite = 0, negative = 0;
  for (const volume::VdbGrid* grid : {&g.density, g.emission ? &*g.emission : nullptr}) {
    if (!grid || !grid->valid()) continue;
    non_finite += grid->replaced_non_finite();
    negative += grid->replaced_negative();
  }
  j["replaced_non_finite_voxels"] = non_finite;
  j["replaced_negative_voxels"] = negative;
  return j;
}

}  // namespace

std::string media_report_json(const plan::LightmapPlan& plan, const std::vector<volume::MediumInput>& media) {
  const plan::MediaAnalysis& a = plan.media_analysis;
  Json j = {{"mode", plan::to_string(plan.media_mode)},
            {"light_paths", a.paths},
            {"extinction", a.extinction},
            {"extinction_standard_error", a.extinction_error},
            {"albedo", a.albedo},
            {"skipped", a.skipped},
            {"media", Json::array()}};
  for (size_t i = 0; i < media.size(); ++i) {
    Json m = medium_json(media[i]);
    m["simulated"] = std::find(plan.media.begin(), plan.media.end(), static_cast<int>(i)) != plan.media.end();
    j["media"].push_back(m);
  }
  return j.dump();
}

}  // namespace kiln::lightmap
