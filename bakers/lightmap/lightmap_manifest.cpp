#include "bakers/lightmap/lightmap_manifest.h"

#include <nlohmann/json.hpp>

namespace kiln::lightmap {
namespace {

using Json = nlohmann::ordered_json;

// The texels of a page that charts cover, by their UV area and by rasterization, over the page's texels.
Json efficiency_json(double chart_texels, size_t valid, int size) {
  const double texels = static_cast<double>(size) * static_cast<double>(size);
  return {{"chart_area", chart_texels / texels}, {"valid_texels", static_cast<double>(valid) / texels}};
}

size_t valid_of(const std::map<std::string, size_t>& valid_texels, const std::string& page) {
  const auto it = valid_texels.find(page);
  return it == valid_texels.end() ? 0 : it->second;
}

Json region_json(const AtlasPack& pack, const AtlasRegion& r) {
  Json j;
  j["page"] = r.page >= 0 ? Json(pack.pages[r.page].name) : Json(nullptr);
  if (r.page >= 0) {
    j["scale"] = {r.scale_offset[0], r.scale_offset[1]};
    j["offset"] = {r.scale_offset[2], r.scale_offset[3]};
    j["region"] = {{"x", r.x}, {"y", r.y}, {"width", r.width}, {"height", r.height}};
  }
  j["texel_density"] = r.density;
  j["texel_density_asked"] = r.density_asked;
  j["world_area"] = r.world_area;
  if (!r.note.empty()) j["note"] = r.note;
  return j;
}

// Totals over the pages.
Json overall_json(const AtlasPack& pack, const std::map<std::string, size_t>& valid_texels) {
  const double texels = page_texels(pack);
  if (!(texels > 0)) return {{"chart_area", 0}, {"valid_texels", 0}};
  size_t valid = 0;
  for (const AtlasPage& p : pack.pages) valid += valid_of(valid_texels, p.name);
  return {{"chart_area", chart_area_fraction(pack)}, {"valid_texels", static_cast<double>(valid) / texels}};
}

std::string dump(const Json& j) { return j.dump(2, ' ', false, Json::error_handler_t::replace) + "\n"; }

}  // namespace

bake::BakeOutput manifest_output(const ManifestInput& in) {
  const AtlasPack& pack = *in.pack;
  Json j;
  j["convention"] =
      "uv_page = uv * scale + offset, per component; uv: the mesh's lightmap UVs (TEXCOORD_1, else TEXCOORD_0), "
      "v = 0 at the top row of the page's images (glTF)";
  j["texel_density"] = in.texel_density;
  j["density_scale"] = pack.density_scale;
  j["padding"] = pack.padding;
  j["efficiency"] = overall_json(pack, in.valid_texels);
  j["pages"] = Json::array();
  for (const AtlasPage& p : pack.pages) {
    Json page;
    page["name"] = p.name;
    page["size"] = p.size;
    page["files"] = Json::array();
    const std::string prefix = p.name + "_";
    if (in.output_names) {
      for (const std::string& name : *in.output_names) {
        if (name.rfind(prefix, 0) == 0) page["files"].push_back(name);
      }
    }
    page["instances"] = Json::array();
    for (uint32_t r : p.regions) page["instances"].push_back(pack.regions[r].source_instance);
    page["own_page"] = p.own_page;
    page["efficiency"] = efficiency_json(p.chart_texels, valid_of(in.valid_texels, p.name), p.size);
    j["pages"].push_back(page);
  }
  // Every instance of the scene as given, packed or not.
  const scene::Scene& sc = *in.input_scene;
  std::vector<int> region_of(sc.instances.size(), -1);
  for (size_t r = 0; r < pack.regions.size(); ++r) {
    if (pack.regions[r].source_instance < region_of.size()) region_of[pack.regions[r].source_instance] = static_cast<int>(r);
  }
  j["instances"] = Json::array();
  for (size_t i = 0; i < sc.instances.size(); ++i) {
    const scene::Instance& inst = sc.instances[i];
    Json e;
    e["index"] = i;
    if (!inst.name.empty()) e["name"] = inst.name;
    e["mesh"] = inst.mesh;
    if (inst.mesh >= 0 && static_cast<size_t>(inst.mesh) < sc.meshes.size()) e["mesh_name"] = sc.meshes[inst.mesh].name;
    if (region_of[i] >= 0) {
      e.update(region_json(pack, pack.regions[region_of[i]]));
    } else {
      e["page"] = nullptr;
      e["note"] = inst.bake ? "not baked: the scene check skipped it or its mesh has no lightmap (report.json's "
                              "scene_problems says why)"
                            : "not baked: bake is false (it casts shadows and bounces light)";
    }
    j["instances"].push_back(e);
  }
  return {"lightmaps.json", "application/json", "", dump(j)};
}

std::string atlas_report_json(const AtlasPack& pack, const std::map<std::string, size_t>& valid_texels) {
  Json j;
  j["pages"] = pack.pages.size();
  j["density_scale"] = pack.density_scale;
  j["padding"] = pack.padding;
  j["seconds"] = pack.seconds;
  j["efficiency"] = overall_json(pack, valid_texels);
  j["page_efficiency"] = Json::array();
  for (const AtlasPage& p : pack.pages) {
    Json e = efficiency_json(p.chart_texels, valid_of(valid_texels, p.name), p.size);
    e["name"] = p.name;
    j["page_efficiency"].push_back(e);
  }
  j["regions"] = Json::array();
  for (const AtlasRegion& r : pack.regions) {
    Json e;
    e["instance"] = r.source_instance;
    e.update(region_json(pack, r));
    j["regions"].push_back(e);
  }
  return j.dump();
}

}  // namespace kiln::lightmap
