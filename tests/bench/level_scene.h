// A generated game level for the large-scene benchmark (level_bench.cpp) and tests: a height-field terrain of rolling
// hills, and thousands of props (rocks, crates, pillars: a few hundred distinct meshes, each with valid lightmap UVs)
// standing on it, under a sun and a sky. Deterministic in its seed.
//
// Lightmaps: the terrain has its own ("terrain"); the instances of a prop mesh share their mesh's lightmap, each in a
// cell of its own (Instance::lightmap_scale_offset, a grid of cells with a margin), as an atlas packer would place
// them.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "bakers/math/constants.h"
#include "bakers/math/rng.h"
#include "bakers/scene/scene.h"

namespace kiln::bench {

struct LevelOptions {
  int terrain_quads = 512;    // per side: 2·n² triangles
  double size = 1000;         // metres across
  double hill_height = 30;    // metres, peak to trough about twice this
  int meshes = 300;           // distinct props
  int instances = 10000;      // props placed
  int prop_detail = 8;        // rings / segments of a prop: rocks have ~2·d² triangles, pillars ~4·d
  uint64_t seed = 1;
};

inline double terrain_height(const LevelOptions& o, double x, double z) {
  const double k = 2 * kPi / o.size;
  return o.hill_height * (0.5 * std::sin(3 * k * x) * std::cos(2 * k * z) + 0.3 * std::sin(7 * k * x + 1) *
                                                                                  std::sin(5 * k * z + 2) +
                          0.2 * std::cos(13 * k * (x + z)));
}

// The terrain: an n × n grid of quads over [−size/2, size/2]², heights terrain_height, normals by central
// differences, lightmap UVs the grid.
inline scene::Mesh terrain_mesh(const LevelOptions& o) {
  scene::Mesh m;
  m.name = "terrain";
  const int n = o.terrain_quads;
  const double step = o.size / n, h = 0.25 * step;
  for (int j = 0; j <= n; ++j) {
    for (int i = 0; i <= n; ++i) {
      const double x = -0.5 * o.size + i * step, z = -0.5 * o.size + j * step;
      m.positions.push_back({x, terrain_height(o, x, z), z});
      const double dx = (terrain_height(o, x + h, z) - terrain_height(o, x - h, z)) / (2 * h);
      const double dz = (terrain_height(o, x, z + h) - terrain_height(o, x, z - h)) / (2 * h);
      m.normals.push_back(normalize(Vec3{-dx, 1, -dz}));
      m.lightmap_uv.push_back({static_cast<double>(i) / n, static_cast<double>(j) / n});
    }
  }
  const auto at = [n](int i, int j) { return static_cast<uint32_t>(j * (n + 1) + i); };
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {  // counter-clockwise seen from +y
      m.indices.insert(m.indices.end(), {at(i, j), at(i, j + 1), at(i + 1, j + 1)});
      m.indices.insert(m.indices.end(), {at(i, j), at(i + 1, j + 1), at(i + 1, j)});
    }
  }
  return m;
}

namespace level_detail {

// A closed lat-long surface r(θ, φ)·(sin θ cos φ, cos θ, sin θ sin φ) with a seam column of its own; lightmap UVs the
// (φ, θ) grid inset by a margin. Outward, counter-clockwise from outside.
template <class Radius>
scene::Mesh lat_long(const std::string& name, int stacks, int slices, const Radius& radius) {
  scene::Mesh m;
  m.name = name;
  constexpr double kInset = 0.02;
  for (int j = 0; j <= stacks; ++j) {
    for (int i = 0; i <= slices; ++i) {
      const double theta = kPi * j / stacks, phi = 2 * kPi * (i % slices) / slices;
      const double r = radius(j, i % slices);
      m.positions.push_back({r * std::sin(theta) * std::cos(phi), r * std::cos(theta), r * std::sin(theta) * std::sin(phi)});
      m.lightmap_uv.push_back({kInset + (1 - 2 * kInset) * i / slices, kInset + (1 - 2 * kInset) * j / stacks});
    }
  }
  const auto at = [slices](int i, int j) { return static_cast<uint32_t>(j * (slices + 1) + i); };
  for (int j = 0; j < stacks; ++j) {
    for (int i = 0; i < slices; ++i) {
      if (j > 0) m.indices.insert(m.indices.end(), {at(i, j), at(i + 1, j), at(i, j + 1)});
      if (j < stacks - 1) m.indices.insert(m.indices.end(), {at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)});
    }
  }
  return m;
}

// A box [−a, a] × [0, 2b] × [−c, c], each face a chart in a 3 × 2 grid of cells.
inline scene::Mesh crate(const std::string& name, double a, double b, double c) {
  const Vec3 lo{-a, 0, -c}, hi{a, 2 * b, c};
  const Vec3 faces[6][4] = {
      {{hi.x, lo.y, hi.z}, {hi.x, lo.y, lo.z}, {hi.x, hi.y, lo.z}, {hi.x, hi.y, hi.z}},
      {{lo.x, lo.y, lo.z}, {lo.x, lo.y, hi.z}, {lo.x, hi.y, hi.z}, {lo.x, hi.y, lo.z}},
      {{lo.x, hi.y, hi.z}, {hi.x, hi.y, hi.z}, {hi.x, hi.y, lo.z}, {lo.x, hi.y, lo.z}},
      {{lo.x, lo.y, lo.z}, {hi.x, lo.y, lo.z}, {hi.x, lo.y, hi.z}, {lo.x, lo.y, hi.z}},
      {{lo.x, lo.y, hi.z}, {hi.x, lo.y, hi.z}, {hi.x, hi.y, hi.z}, {lo.x, hi.y, hi.z}},
      {{hi.x, lo.y, lo.z}, {lo.x, lo.y, lo.z}, {lo.x, hi.y, lo.z}, {hi.x, hi.y, lo.z}},
  };
  scene::Mesh m;
  m.name = name;
  constexpr double kMargin = 0.04;
  const double w = (1 - 4 * kMargin) / 3, h = (1 - 3 * kMargin) / 2;
  for (int f = 0; f < 6; ++f) {
    const uint32_t base = static_cast<uint32_t>(m.positions.size());
    const double u0 = kMargin + (f % 3) * (w + kMargin), v0 = kMargin + (f / 3) * (h + kMargin);
    const Point2 uv[4] = {{u0, v0 + h}, {u0 + w, v0 + h}, {u0 + w, v0}, {u0, v0}};
    for (int k = 0; k < 4; ++k) {
      m.positions.push_back(faces[f][k]);
      m.lightmap_uv.push_back(uv[k]);
    }
    m.indices.insert(m.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
  }
  return m;
}

// A cylinder of radius r and height 2b standing on y = 0 with its caps: the side a grid in the lower half of the UV
// square, the caps discs in the upper half.
inline scene::Mesh pillar(const std::string& name, double r, double b, int segments) {
  scene::Mesh m;
  m.name = name;
  const int rows = 4;
  for (int j = 0; j <= rows; ++j) {
    for (int i = 0; i <= segments; ++i) {
      const double phi = 2 * kPi * (i % segments) / segments;
      m.positions.push_back({r * std::cos(phi), 2 * b * j / rows, -r * std::sin(phi)});
      m.lightmap_uv.push_back({0.02 + 0.96 * i / segments, 0.52 + 0.46 * (rows - j) / rows});
    }
  }
  for (int j = 0; j < rows; ++j) {
    for (int i = 0; i < segments; ++i) {
      const uint32_t a = j * (segments + 1) + i, c = a + segments + 1;
      m.indices.insert(m.indices.end(), {a, a + 1, c + 1, a, c + 1, c});
    }
  }
  for (int cap = 0; cap < 2; ++cap) {
    const double y = cap ? 2 * b : 0, cu = cap ? 0.75 : 0.25;
    const uint32_t centre = static_cast<uint32_t>(m.positions.size());
    m.positions.push_back({0, y, 0});
    m.lightmap_uv.push_back({cu, 0.25});
    for (int i = 0; i < segments; ++i) {
      const double phi = 2 * kPi * i / segments;
      m.positions.push_back({r * std::cos(phi), y, -r * std::sin(phi)});
      m.lightmap_uv.push_back({cu + 0.22 * std::cos(phi), 0.25 - 0.22 * std::sin(phi)});
    }
    for (int i = 0; i < segments; ++i) {
      const uint32_t a = centre + 1 + i, b2 = centre + 1 + (i + 1) % segments;
      if (cap)
        m.indices.insert(m.indices.end(), {centre, a, b2});  // top, facing +y
      else
        m.indices.insert(m.indices.end(), {centre, b2, a});  // bottom, facing −y
    }
  }
  return m;
}

}  // namespace level_detail

// The level: terrain (mesh 0, instance 0), then `meshes` props (rocks, crates, pillars in turn) and `instances`
// instances of them spread over the terrain, each turned about y, scaled by 0.6–1.6 and sunk 10 cm into the ground.
// Lights: a sun 40° above the horizon and a constant sky.
inline scene::Scene level_scene(const LevelOptions& o) {
  scene::Scene s;
  scene::SceneMaterial ground;
  ground.name = "ground";
  ground.base_color = Rgb{0.35, 0.3, 0.2};
  scene::SceneMaterial stone;
  stone.name = "stone";
  stone.base_color = Rgb{0.5};
  s.materials = {ground, stone};
  s.meshes.push_back(terrain_mesh(o));
  Pcg32 rng(o.seed);
  const int d = std::max(3, o.prop_detail);
  for (int k = 0; k < o.meshes; ++k) {
    scene::Mesh m;
    const std::string name = "prop" + std::to_string(k);
    if (k % 3 == 0) {
      std::vector<double> bumps(static_cast<size_t>((d + 1) * 2 * d));
      for (double& b : bumps) b = 0.8 + 0.4 * rng.uniform();
      m = level_detail::lat_long(name, d, 2 * d, [&](int j, int i) {
        return (j == 0 || j == d) ? 1.0 : bumps[static_cast<size_t>(j * 2 * d + i)];
      });
    } else if (k % 3 == 1) {
      m = level_detail::crate(name, 0.5 + rng.uniform(), 0.5 + rng.uniform(), 0.5 + rng.uniform());
    } else {
      m = level_detail::pillar(name, 0.3 + 0.4 * rng.uniform(), 1 + 2 * rng.uniform(), 2 * d);
    }
    m.material.assign(m.indices.size() / 3, 1);
    s.meshes.push_back(std::move(m));
  }
  scene::Instance terrain;
  terrain.mesh = 0;
  s.instances.push_back(terrain);
  // Instances of each mesh, counted first so each gets a cell of its mesh's atlas.
  std::vector<int> mesh_of(static_cast<size_t>(o.instances)), count(static_cast<size_t>(o.meshes), 0);
  for (int i = 0; i < o.instances && o.meshes > 0; ++i)
    mesh_of[static_cast<size_t>(i)] = static_cast<int>(rng.next_u32() % static_cast<uint32_t>(o.meshes));
  for (int m : mesh_of) ++count[static_cast<size_t>(m)];
  std::vector<int> placed(static_cast<size_t>(o.meshes), 0);
  for (int i = 0; i < o.instances && o.meshes > 0; ++i) {
    const int m = mesh_of[static_cast<size_t>(i)];
    const int cells = static_cast<int>(std::ceil(std::sqrt(count[static_cast<size_t>(m)])));
    const int cell = placed[static_cast<size_t>(m)]++;
    const double x = (rng.uniform() - 0.5) * 0.95 * o.size, z = (rng.uniform() - 0.5) * 0.95 * o.size;
    const double yaw = 2 * kPi * rng.uniform(), sc = 0.6 + rng.uniform();
    const double c = std::cos(yaw) * sc, sn = std::sin(yaw) * sc;
    scene::Instance inst;
    inst.mesh = 1 + m;
    inst.to_world.m = {c, 0, sn, x, 0, sc, 0, terrain_height(o, x, z) - 0.1, -sn, 0, c, z};
    const double cs = 1.0 / cells;
    inst.lightmap_scale_offset = {cs, cs, (cell % cells) * cs, (cell / cells) * cs};
    s.instances.push_back(inst);
  }
  scene::Light sun;
  sun.type = scene::LightShape::directional;
  sun.direction = normalize(Vec3{-0.5, -std::tan(40 * kPi / 180) * std::sqrt(0.5), -0.5});  // 40° above the horizon
  sun.color = Rgb{3.0};
  s.lights.push_back(sun);
  s.environment.constant = Rgb{0.4, 0.5, 0.7};
  return s;
}

}  // namespace kiln::bench
