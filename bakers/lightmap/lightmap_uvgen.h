// Generated lightmap UVs in a lightmap bake (bakers/uvgen/uv_generator.h): which meshes get them, at which texel
// size, and what the bake hands over about them.
//
// Which: with GenerateUvs::automatic the meshes whose own lightmap UVs are unusable (none, outside [0, 1], or
// overlapping themselves: uvgen::unusable_lightmap_uvs); with `always` every mesh; with `never` none. Only meshes
// that some baking instance uses, with a triangle that can be charted.
//
// At which size: the charts' padding is in texels of the lightmap the mesh bakes into, so the generator packs for it.
//   - With atlas pages (atlas.texel_density > 0): at the smallest density any baking instance of the mesh asks for
//     (its own or the job's, times the cube root of its transform's volume scale, the linear scale of a uniform
//     one), in the smallest square that holds the charts; the atlas packer then gives the mesh about that square's
//     texels. A square larger than a page (less padding) is packed again into the page's size.
//   - Without: into a square of the smallest resolution any baking instance's lightmap has (times the smaller scale
//     of its lightmap_scale_offset), as densely as the charts fit.
//
// What: the mesh replaces the input's in the scene the bake checks and bakes; NAME_uv.bin (NAME the mesh's name made
// a safe, unique file stem; "mesh<index>" when it has none) holds the mesh with its generated lightmap UVs in the kiln
// mesh layout (proto/kiln.proto, above `message Mesh`), so an engine can draw it with the lightmaps; report.json's
// `generated_uvs` lists each mesh with its charts and quality.
#pragma once

#include <string>
#include <vector>

#include "bakers/bake/output.h"
#include "bakers/bake/stop.h"
#include "bakers/lightmap/lightmap_bake.h"
#include "bakers/uvgen/uv_generator.h"

namespace kiln::lightmap {

struct GeneratedMeshUvs {
  int mesh = 0;        // into the scene's meshes
  std::string name;    // the mesh's name
  std::string reason;  // why its own UVs were not used ("always" when asked for every mesh)
  std::string file;    // NAME_uv.bin
  std::string bytes;   // its contents: the generated mesh in the kiln mesh layout
  uvgen::UvgenStats stats;
};

// Replaces the meshes that get generated UVs in `scene` (the input's, before the scene check) and says which.
std::vector<GeneratedMeshUvs> generate_scene_uvs(scene::Scene& scene, const LightmapBakeInput& input,
                                                 const bake::StopCheck& stop);

// NAME_uv.bin of a generated mesh (its bytes moved out).
bake::BakeOutput generated_uvs_output(GeneratedMeshUvs& generated);

// report.json's `generated_uvs`: mode, and per mesh its name, reason, file, charts (and how each was flattened),
// atlas square and density, utilisation, L2 stretch, mean angle error, flipped and overlapping triangles, vertices
// added and seconds.
std::string generated_uvs_json(uvgen::GenerateUvs mode, const std::vector<GeneratedMeshUvs>& meshes);

}  // namespace kiln::lightmap
