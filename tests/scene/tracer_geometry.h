// Generated meshes and transforms for the tracer's tests and benchmark: a UV sphere, a tessellated square, a box
// room, and the similarity transforms the scale tests apply.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "bakers/math/constants.h"
#include "bakers/scene/scene.h"

namespace kiln::scene::test {

// An instance of mesh `mesh` (designated initializers would leave -Wextra complaining about the other members).
inline Instance instance(int mesh, const Transform& to_world = {}, const std::string& lightmap = {}) {
  Instance i;
  i.mesh = mesh;
  i.to_world = to_world;
  i.lightmap = lightmap;
  return i;
}

// x' = s·x + T.
inline Transform scale_translate(double s, const Vec3& t) {
  Transform m;
  m.m = {s, 0, 0, t.x, 0, s, 0, t.y, 0, 0, s, t.z};
  return m;
}

// a ∘ b: b first.
inline Transform compose(const Transform& a, const Transform& b) {
  Transform r;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 4; ++j) {
      double v = j == 3 ? a.m[4 * i + 3] : 0.0;
      for (int k = 0; k < 3; ++k) v += a.m[4 * i + k] * b.m[4 * k + j];
      r.m[4 * i + j] = v;
    }
  }
  return r;
}

// Unit sphere about the origin, `stacks` × `slices`, poles as single vertices (the fans around them are thin
// triangles), outward normals, counter-clockwise from outside. Odd rings are turned by half a slice, so no two
// triangles are coplanar (a lat-long grid's quads are planar, and rounding their vertices to float far from the
// origin would fold them slightly concave): the mesh is strictly convex.
inline Mesh uv_sphere(int stacks, int slices, const std::string& name = "sphere") {
  Mesh m;
  m.name = name;
  m.positions.push_back({0, 1, 0});
  for (int i = 1; i < stacks; ++i) {
    const double theta = kPi * i / stacks;
    for (int j = 0; j < slices; ++j) {
      const double phi = 2 * kPi * (j + 0.5 * (i % 2)) / slices;
      m.positions.push_back({std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi)});
    }
  }
  m.positions.push_back({0, -1, 0});
  m.normals = m.positions;
  const uint32_t south = static_cast<uint32_t>(m.positions.size() - 1);
  auto ring = [&](int i, int j) { return static_cast<uint32_t>(1 + (i - 1) * slices + (j % slices)); };
  for (int j = 0; j < slices; ++j) m.indices.insert(m.indices.end(), {0, ring(1, j + 1), ring(1, j)});
  for (int i = 1; i < stacks - 1; ++i)
    for (int j = 0; j < slices; ++j) {
      const uint32_t a = ring(i, j), b = ring(i, j + 1), c = ring(i + 1, j), d = ring(i + 1, j + 1);
      if (i % 2 == 0)  // ring i + 1 is half a slice ahead: c lies between a and b
        m.indices.insert(m.indices.end(), {a, b, c, b, d, c});
      else  // ring i is half a slice ahead: b lies between c and d
        m.indices.insert(m.indices.end(), {a, b, d, a, d, c});
    }
  for (int j = 0; j < slices; ++j)
    m.indices.insert(m.indices.end(), {south, ring(stacks - 1, j), ring(stacks - 1, j + 1)});
  return m;
}

// The square [−1,1]² in the xz-plane at y = 0, n×n quads, facing +y, lightmap UVs = (x, z) mapped to [0,1].
inline Mesh square(int n, const std::string& name = "square") {
  Mesh m;
  m.name = name;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const double x = -1 + 2.0 * i / n, z = -1 + 2.0 * j / n;
      m.positions.push_back({x, 0, z});
      m.normals.push_back({0, 1, 0});
      m.lightmap_uv.push_back({double(i) / n, double(j) / n});
      m.uv.push_back({double(i) / n, double(j) / n});
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const uint32_t a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      m.indices.insert(m.indices.end(), {a, c, b, b, c, d});
    }
  return m;
}

// The six faces of [−1,1]³, each an n×n grid, facing outwards (inwards if `inward`).
inline Mesh box(int n, bool inward, const std::string& name = "box") {
  Mesh out;
  out.name = name;
  const Mesh face = square(n);
  // Rotations taking +y to each axis direction (rows of a 3×3 matrix), then a shift by the face normal.
  const double rot[6][9] = {{1, 0, 0, 0, 1, 0, 0, 0, 1},  {1, 0, 0, 0, -1, 0, 0, 0, -1}, {0, 1, 0, -1, 0, 0, 0, 0, 1},
                            {0, -1, 0, 1, 0, 0, 0, 0, 1}, {1, 0, 0, 0, 0, -1, 0, 1, 0},  {1, 0, 0, 0, 0, 1, 0, -1, 0}};
  for (const auto& r : rot) {
    const uint32_t base = static_cast<uint32_t>(out.positions.size());
    const Vec3 n{r[1], r[4], r[7]};
    for (const Vec3& p : face.positions)
      out.positions.push_back(Vec3{r[0] * p.x + r[1] * p.y + r[2] * p.z, r[3] * p.x + r[4] * p.y + r[5] * p.z,
                                   r[6] * p.x + r[7] * p.y + r[8] * p.z} +
                              n);
    for (size_t k = 0; k < face.positions.size(); ++k) out.normals.push_back(inward ? -n : n);
    for (size_t t = 0; t < face.indices.size(); t += 3) {
      const uint32_t a = base + face.indices[t], b = base + face.indices[t + 1], c = base + face.indices[t + 2];
      if (inward)
        out.indices.insert(out.indices.end(), {a, c, b});
      else
        out.indices.insert(out.indices.end(), {a, b, c});
    }
  }
  return out;
}

// A box room of half-size `half` (inward walls, `n`×`n` quads a wall) with a sphere and two boxes standing in it:
// the benchmark's and the scale tests' scene. About 6n² + 2·6m² + 2·stacks·slices triangles.
inline Scene box_room(int n = 16, int box_n = 4, int stacks = 24, int slices = 48, double half = 5) {
  Scene s;
  s.materials.resize(1);
  s.meshes = {box(n, true, "room"), uv_sphere(stacks, slices), box(box_n, false, "block")};
  s.instances.push_back(instance(0, scale_translate(half, {0, 0, 0})));
  s.instances.push_back(instance(1, scale_translate(0.3 * half, {0.3 * half, -0.5 * half, 0.2 * half})));
  // A block rotated 30° about y and scaled non-uniformly, and a tall thin one; neither touches the floor (coplanar
  // faces facing each other would make hits there ambiguous for the scale tests).
  const double c = std::cos(kPi / 6), sn = std::sin(kPi / 6);
  Transform rot;
  rot.m = {c, 0, sn, 0, 0, 1, 0, 0, -sn, 0, c, 0};
  Transform scale;
  scale.m = {0.2 * half, 0, 0, -0.4 * half, 0, 0.35 * half, 0, -0.64 * half, 0, 0, 0.15 * half, -0.3 * half};
  s.instances.push_back(instance(2, compose(scale, rot)));
  s.instances.push_back(instance(2, scale_translate(0.1 * half, {-0.6 * half, -0.9 * half, 0.6 * half})));
  s.instances.back().to_world.m[5] = 0.8 * half;  // tall: y from −0.99·half to 0.61·half, just off the floor
  s.instances.back().to_world.m[7] = -0.19 * half;
  return s;
}

}  // namespace kiln::scene::test
