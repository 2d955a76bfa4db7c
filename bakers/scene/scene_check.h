// Scene validation before a bake: finds what is wrong with a scene, repairs what can be repaired, drops what cannot
// be traced, marks what cannot be baked, and says so, naming the mesh, instance and triangle. What can be baked still
// bakes: one bad triangle never fails a scene.
//
//   problem                                  what happens                                  kind
//   mesh without lightmap UVs                casts shadows, bounces light, gets no lightmap no_lightmap_uv
//   per-vertex array of the wrong size       normals/uv: ignored; lightmap UVs: no lightmap array_size_mismatch
//   index count not a multiple of 3          the trailing indices ignored                   index_count
//   index out of range                       triangle dropped                               index_out_of_range
//   NaN/Inf position                         triangles using it dropped                     non_finite_vertex
//   zero area in 3-D (at float precision)    triangle dropped                               degenerate_triangle
//   lightmap UV outside [0,1] (or NaN)       traced, not baked                              lightmap_uv_out_of_range
//   zero lightmap-UV area                    traced, not baked                              degenerate_lightmap_uv
//   overlapping UV triangles in a lightmap   both still baked (they share texels)           overlapping_lightmap_uv
//   material index out of range              material 0                                     material_out_of_range
//   per-triangle material array wrong size   material 0 for every triangle                  array_size_mismatch
//   normal NaN, Inf or zero                  the vertex's geometric normal                  bad_normal
//   texture UV NaN or Inf                    (0, 0)                                         non_finite_uv
//   instance transform singular/non-finite   instance skipped                               bad_transform
//   instance of a mesh that does not exist   instance skipped                               bad_instance_mesh
//   lightmap scale/offset invalid            instance not baked                             bad_lightmap_scale_offset
//   no materials                             a grey Lambert material added                  no_materials
//   material texture index out of range      texture ignored                                bad_texture
//   base colour not finite or outside [0,1]  NaN → 0, clamped to [0, 1]                     bad_material_value
//   emission not finite or negative          any NaN/±Inf channel → black, negative → 0       bad_material_value
//   lightmap name not a safe file name       its files get a safe, unique name (listed)      renamed_lightmap
//     or the same file name as another's
//
// The cleaned scene keeps every mesh and every vertex (so vertex indices keep their meaning; non-finite positions,
// which nothing references any more, become 0) but only the triangles that can be traced; `source_triangle` maps
// them back to the input's triangle indices, which the report uses. Its instances are the ones that were not skipped,
// each with its lightmap name resolved (never empty for an instance that bakes) and made a safe file stem.
#pragma once

#include <array>
#include <map>
#include <cstdint>
#include <string>
#include <vector>

#include "bakers/scene/scene.h"

namespace kiln::scene {

enum class Severity { warning, error };  // warning: repaired or only not baked; error: dropped from the scene

enum class ProblemKind {
  no_lightmap_uv,
  array_size_mismatch,
  index_count,
  index_out_of_range,
  non_finite_vertex,
  degenerate_triangle,
  lightmap_uv_out_of_range,
  degenerate_lightmap_uv,
  overlapping_lightmap_uv,
  material_out_of_range,
  bad_normal,
  non_finite_uv,
  bad_transform,
  bad_instance_mesh,
  bad_lightmap_scale_offset,
  no_materials,
  bad_texture,
  bad_material_value,
  renamed_lightmap,
};
inline constexpr int kProblemKindCount = static_cast<int>(ProblemKind::renamed_lightmap) + 1;
const char* to_string(ProblemKind kind);
const char* to_string(Severity severity);

struct Problem {
  Severity severity = Severity::warning;
  ProblemKind kind = ProblemKind::no_lightmap_uv;
  int mesh = -1;                // into the input's meshes; -1: not about one mesh
  int instance = -1;            // into the input's instances; -1: about the mesh in every instance
  int64_t triangle = -1;        // into the input mesh's triangles (indices[3t..3t+2]); -1: not about one triangle
  int64_t vertex = -1;          // for vertex problems (bad_normal, non_finite_uv)
  int64_t other_triangle = -1;  // overlapping_lightmap_uv: the other triangle of the pair (of mesh `other_mesh`,
  int other_mesh = -1, other_instance = -1;  // instance `other_instance`)
  std::string what;                          // for people: what is wrong, with the values
  std::string action;                        // for people: what the bake does about it
};

struct SceneReport {
  std::vector<Problem> problems;                    // at most `max_listed_per_kind` of each kind, in the order found
  std::array<int64_t, kProblemKindCount> counts{};  // every problem found, listed or not
  int64_t count(ProblemKind kind) const { return counts[static_cast<int>(kind)]; }
  int64_t total() const;
  bool clean() const { return total() == 0; }
  // One line per kind found ("12 × degenerate_triangle (3 listed): …") then the listed problems, for people.
  std::string summary() const;
};

struct CheckOptions {
  size_t max_listed_per_kind = 100;
  // false: no overlap check yet, for a caller that places the instances in their lightmaps after the check (an atlas
  // packer) and then calls check_overlaps.
  bool overlaps = true;
};

struct CheckedScene {
  Scene scene;  // cleaned, see the top of this file
  // Per cleaned mesh, per cleaned triangle: its index in the input mesh, and whether it bakes into a lightmap (false
  // for meshes without lightmap UVs, UVs outside [0,1], zero UV area). Traced either way.
  struct MeshTriangles {
    std::vector<uint32_t> source_triangle;
    std::vector<uint8_t> bake;
  };
  std::vector<MeshTriangles> triangles;   // one per mesh
  std::vector<uint32_t> source_instance;  // per cleaned instance: its index in the input
  // The cleaned instances name their lightmaps by file stem (lightmap_file_names.h); each lightmap whose name in the
  // input differs from its stem, stem → input name.
  std::map<std::string, std::string> renamed_lightmaps;
  SceneReport report;

  // The name the input gave the lightmap a cleaned instance calls `stem` (what the job's per-lightmap settings use).
  const std::string& input_lightmap_name(const std::string& stem) const;
};

// Never throws for bad data: everything wrong is in the report.
CheckedScene check_scene(const Scene& scene, const CheckOptions& options = {});

// The overlapping_lightmap_uv check of check_scene, on a checked scene whose instances' lightmaps or scale and offset
// changed since (an atlas packed them): its problems are added to checked.report.
void check_overlaps(CheckedScene& checked, const CheckOptions& options = {});

// The lightmap an instance bakes into: its `lightmap`, else its mesh's name, else "mesh<index>".
std::string resolved_lightmap_name(const Scene& scene, const Instance& instance);

// True if the 3×3 part of `t` is invertible well enough to transform normals (see scene_check.cpp) and every entry is
// finite.
bool usable_transform(const Transform& t);

}  // namespace kiln::scene
