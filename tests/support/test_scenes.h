// Scenes with known answers for the lightmap tests: each built in code, with lightmap UVs, in the units given.
#pragma once

#include "bakers/scene/scene.h"

namespace kiln::test {

// A Lambertian material (no specular lobe) of albedo `rho`.
scene::SceneMaterial lambert_material(const std::string& name, double rho, Rgb emission = Rgb{0.0});

// Appends a quad p0 p1 p2 p3 (counter-clockwise seen from its front) as a mesh of its own named `name`, subdivided
// n × n, lightmap UVs spanning [0, 1]² (p0 at (0, 1), p1 at (1, 1), p2 at (1, 0)), with one instance. Returns the
// mesh index.
int add_quad(scene::Scene& s, const std::string& name, Vec3 p0, Vec3 p1, Vec3 p2, Vec3 p3, uint32_t material,
             int n = 1);

// Appends an axis-aligned box (all six faces outward, or inward for a room) as one mesh with a lightmap atlas (the
// faces in a 3 × 2 grid with margins). Returns the mesh index.
int add_box(scene::Scene& s, const std::string& name, Vec3 lo, Vec3 hi, uint32_t material, bool inward = false);

// Appends a UV sphere (lat-long lightmap UVs, `rings` × 2·`rings` quads), facing outward or inward, with the
// sphere's vertex normals (smooth) or none (each facet its geometric normal).
int add_sphere(scene::Scene& s, const std::string& name, Vec3 centre, double radius, int rings, uint32_t material,
               bool inward = false, bool smooth = true);

// Multiplies every position of every mesh and every light position, size and distance by `scale` and then adds
// `offset` (directions, radiances and intensities unchanged; point and spot intensities scaled by scale² so that
// irradiance at scaled distances is unchanged).
void scale_scene(scene::Scene& s, double scale, Vec3 offset = {});

}  // namespace kiln::test
