#include "tests/support/test_scenes.h"

#include <cmath>

#include "bakers/math/constants.h"

namespace kiln::test {
namespace {

constexpr double kMargin = 1.0 / 16;  // of an atlas, around and between charts

Vec3 bilinear(const Vec3 p[4], double s, double t) {
  return p[0] * ((1 - s) * (1 - t)) + p[1] * (s * (1 - t)) + p[2] * (s * t) + p[3] * ((1 - s) * t);
}

// Appends an n × n grid over quad p (CCW from the front) to `mesh`, lightmap UVs in the rectangle [u0,u1]×[v0,v1]
// with p0 at (u0, v1) and p2 at (u1, v0).
void append_grid(scene::Mesh& mesh, const Vec3 p[4], int n, uint32_t material, double u0, double v0, double u1,
                 double v1) {
  const uint32_t base = static_cast<uint32_t>(mesh.positions.size());
  for (int j = 0; j <= n; ++j) {
    for (int i = 0; i <= n; ++i) {
      const double s = static_cast<double>(i) / n, t = static_cast<double>(j) / n;
      mesh.positions.push_back(bilinear(p, s, t));
      mesh.lightmap_uv.push_back({u0 + s * (u1 - u0), v1 - t * (v1 - v0)});
      mesh.uv.push_back({s, 1 - t});
    }
  }
  auto at = [&](int i, int j) { return base + static_cast<uint32_t>(j * (n + 1) + i); };
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      mesh.indices.insert(mesh.indices.end(), {at(i, j), at(i + 1, j), at(i + 1, j + 1)});
      mesh.indices.insert(mesh.indices.end(), {at(i, j), at(i + 1, j + 1), at(i, j + 1)});
      mesh.material.insert(mesh.material.end(), {material, material});
    }
  }
}

int add_mesh(scene::Scene& s, scene::Mesh mesh) {
  s.meshes.push_back(std::move(mesh));
  scene::Instance inst;
  inst.mesh = static_cast<int>(s.meshes.size() - 1);
  s.instances.push_back(inst);
  return inst.mesh;
}

}  // namespace

scene::SceneMaterial lambert_material(const std::string& name, double rho, Rgb emission) {
  scene::SceneMaterial m;
  m.name = name;
  m.bsdf.diffuse.model = brdf::Model::lambert;
  m.bsdf.diffuse.albedo = Rgb{rho};
  m.bsdf.specular.model = brdf::Model::lambert;  // weightless: the material is purely Lambertian
  m.bsdf.combine = brdf::Combine::weights;
  m.bsdf.specular_weight = 0.0;
  m.emission = emission;
  return m;
}

int add_quad(scene::Scene& s, const std::string& name, Vec3 p0, Vec3 p1, Vec3 p2, Vec3 p3, uint32_t material, int n) {
  scene::Mesh mesh;
  mesh.name = name;
  const Vec3 p[4] = {p0, p1, p2, p3};
  append_grid(mesh, p, n, material, 0, 0, 1, 1);
  return add_mesh(s, std::move(mesh));
}

int add_box(scene::Scene& s, const std::string& name, Vec3 lo, Vec3 hi, uint32_t material, bool inward) {
  const Vec3 faces[6][4] = {
      {{hi.x, lo.y, hi.z}, {hi.x, lo.y, lo.z}, {hi.x, hi.y, lo.z}, {hi.x, hi.y, hi.z}},  // +x
      {{lo.x, lo.y, lo.z}, {lo.x, lo.y, hi.z}, {lo.x, hi.y, hi.z}, {lo.x, hi.y, lo.z}},  // −x
      {{lo.x, hi.y, hi.z}, {hi.x, hi.y, hi.z}, {hi.x, hi.y, lo.z}, {lo.x, hi.y, lo.z}},  // +y
      {{lo.x, lo.y, lo.z}, {hi.x, lo.y, lo.z}, {hi.x, lo.y, hi.z}, {lo.x, lo.y, hi.z}},  // −y
      {{lo.x, lo.y, hi.z}, {hi.x, lo.y, hi.z}, {hi.x, hi.y, hi.z}, {lo.x, hi.y, hi.z}},  // +z
      {{hi.x, lo.y, lo.z}, {lo.x, lo.y, lo.z}, {lo.x, hi.y, lo.z}, {hi.x, hi.y, lo.z}},  // −z
  };
  scene::Mesh mesh;
  mesh.name = name;
  const double cell_w = (1 - 4 * kMargin) / 3, cell_h = (1 - 3 * kMargin) / 2;
  for (int f = 0; f < 6; ++f) {
    Vec3 p[4] = {faces[f][0], faces[f][1], faces[f][2], faces[f][3]};
    if (inward) std::swap(p[1], p[3]);  // reversed winding: the front faces the inside
    const int c = f % 3, r = f / 3;
    const double u0 = kMargin + c * (cell_w + kMargin), v0 = kMargin + r * (cell_h + kMargin);
    append_grid(mesh, p, 1, material, u0, v0, u0 + cell_w, v0 + cell_h);
  }
  return add_mesh(s, std::move(mesh));
}

int add_sphere(scene::Scene& s, const std::string& name, Vec3 centre, double radius, int rings, uint32_t material,
               bool inward, bool smooth) {
  scene::Mesh mesh;
  mesh.name = name;
  const int segments = 2 * rings;
  for (int j = 0; j <= rings; ++j) {
    for (int i = 0; i <= segments; ++i) {
      const double theta = kPi * j / rings, phi = 2 * kPi * i / segments;
      const Vec3 d{std::sin(theta) * std::sin(phi), std::cos(theta), -std::sin(theta) * std::cos(phi)};
      mesh.positions.push_back(centre + d * radius);
      if (smooth) mesh.normals.push_back(inward ? -d : d);
      const double u = static_cast<double>(i) / segments, v = static_cast<double>(j) / rings;
      mesh.lightmap_uv.push_back({kMargin + (1 - 2 * kMargin) * u, kMargin + (1 - 2 * kMargin) * v});
      mesh.uv.push_back({u, v});
    }
  }
  auto at = [&](int i, int j) { return static_cast<uint32_t>(j * (segments + 1) + i); };
  auto triangle = [&](uint32_t a, uint32_t b, uint32_t c) {
    const Vec3 n = cross(mesh.positions[b] - mesh.positions[a], mesh.positions[c] - mesh.positions[a]);
    if (length(n) == 0) return;  // the collapsed triangle of a quad touching a pole
    const Vec3 outward = (mesh.positions[a] + mesh.positions[b] + mesh.positions[c]) / 3.0 - centre;
    const bool faces_out = dot(n, outward) > 0;
    if (faces_out != inward) {
      mesh.indices.insert(mesh.indices.end(), {a, b, c});
    } else {
      mesh.indices.insert(mesh.indices.end(), {a, c, b});
    }
    mesh.material.push_back(material);
  };
  for (int j = 0; j < rings; ++j) {
    for (int i = 0; i < segments; ++i) {
      triangle(at(i, j), at(i + 1, j), at(i + 1, j + 1));
      triangle(at(i, j), at(i + 1, j + 1), at(i, j + 1));
    }
  }
  return add_mesh(s, std::move(mesh));
}

void scale_scene(scene::Scene& s, double scale, Vec3 offset) {
  for (scene::Instance& inst : s.instances) {
    auto& m = inst.to_world.m;
    const double o[3] = {offset.x, offset.y, offset.z};
    for (int row = 0; row < 3; ++row) {
      for (int col = 0; col < 3; ++col) m[row * 4 + col] *= scale;
      m[row * 4 + 3] = m[row * 4 + 3] * scale + o[row];
    }
  }
  for (scene::Light& l : s.lights) {
    l.position = l.position * scale + offset;
    l.u_axis = l.u_axis * scale;
    l.v_axis = l.v_axis * scale;
    l.radius *= scale;
    if (l.type == scene::LightType::point || l.type == scene::LightType::spot) l.color = l.color * (scale * scale);
  }
}

}  // namespace kiln::test
