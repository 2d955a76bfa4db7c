// lightmaps.json, written by a bake that packs atlas pages (atlas_pack.h): what an engine needs to look its instances
// up in the pages. For every instance of the scene (by its index in the input, with its mesh and name) its page, the
// scale and offset that map its mesh's lightmap UVs into the page (uv_page = uv * scale + offset, per component,
// numbers in round-trip precision: parsed back they are the doubles the bake used), its region in texels and the
// texel density reached; an instance that was not baked has page null and says why. For every page its size, its
// output files, its instances and its pack efficiency: the texels its charts cover (UV area) and its valid texels
// (rasterized, conservative: a texel a chart touches counts) over the page's texels.
#pragma once

#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "bakers/bake/output.h"
#include "bakers/lightmap/atlas_pack.h"
#include "bakers/scene/scene.h"

namespace kiln::lightmap {

struct ManifestInput {
  const scene::Scene* input_scene = nullptr;  // the scene as given: instance indices, names and meshes
  const AtlasPack* pack = nullptr;
  double texel_density = 0;                        // the job's
  std::map<std::string, size_t> valid_texels;      // per page name: valid texels after rasterization and leaks
  const std::vector<std::string>* output_names = nullptr;  // of the bake's outputs so far: each page's files
};

// lightmaps.json as a bake output (application/json), ending in a newline.
bake::BakeOutput manifest_output(const ManifestInput& in);

// The atlas's part of report.json: the settings, each page's efficiency and each instance's region and density, as
// JSON text (an object).
std::string atlas_report_json(const AtlasPack& pack, const std::map<std::string, size_t>& valid_texels);

}  // namespace kiln::lightmap
