// Meshes without lightmap UVs for the lightmap-UV generator's tests and benchmark (bakers/uvgen/): shapes whose
// charts and distortion are known (a plane, a cube), and the generated set (a torus, a sphere, a
// character-like blob, a room with furniture, a scan-like mesh). Each has texture UVs where an exporter would give
// them (a lat-long seam, a mirrored character), and no lightmap UVs unless said.
#pragma once

#include <string>
#include <vector>

#include "bakers/scene/scene.h"

namespace kiln::test {

// A flat n × n grid of side `size` in the XZ plane facing +Y, texture UVs spanning [0, 1]².
scene::Mesh uv_plane(int n, double size = 1);
// A unit cube: with split normals (24 vertices, each face its own normals, as exporters write hard edges), or 8
// shared vertices and no normals.
scene::Mesh uv_cube(bool split_normals);
// Tori, spheres: parametric grids with smooth normals and texture UVs, the seam's vertices duplicated.
scene::Mesh uv_torus(int major = 48, int minor = 24, double r_major = 1, double r_minor = 0.35);
scene::Mesh uv_sphere(int rings = 32, double radius = 1);
// A character-like blob, symmetric about x = 0: a body, a head and four limbs as one closed-ish surface; its texture
// UVs mirror (u from |x|, the halves sharing texels, as a symmetric character's do), and with `mirrored_lightmap` they
// are also its lightmap UVs (TEXCOORD_0 standing in for TEXCOORD_1, as the importer does).
scene::Mesh uv_blob(bool mirrored_lightmap = false);
// A room (an inward box, 4 × 3 × 5) with a table and two chairs (outward boxes), one mesh, split normals.
scene::Mesh uv_room();
// A closed, bumpy, scan-like surface of about `triangles` triangles: shared vertices, no normals, no texture UVs.
scene::Mesh uv_scan(int triangles = 100000);

struct NamedMesh {
  std::string name;
  scene::Mesh mesh;
};
// The generated set of the benchmark and docs/UVGEN.md, in that order.
std::vector<NamedMesh> uv_generated_set();

}  // namespace kiln::test
