#include "tests/support/test_scenes.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

#include "bakers/envmap/cubemap.h"
#include "bakers/image/exr.h"
#include "bakers/lightmap/texels.h"
#include "bakers/math/constants.h"
#include "bakers/scene/polygon_irradiance.h"

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

scene::Transform translate_scale(Vec3 t, double s) {
  scene::Transform x;
  x.m = {s, 0, 0, t.x, 0, s, 0, t.y, 0, 0, s, t.z};
  return x;
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
    if (l.type == scene::LightShape::point || l.type == scene::LightShape::spot) l.color = l.color * (scale * scale);
  }
}

// ---- Lightmap test helpers ----

int add_floor(scene::Scene& s, double size, uint32_t material, int n) {
  const double h = size / 2;
  return add_quad(s, "floor", {-h, 0, h}, {h, 0, h}, {h, 0, -h}, {-h, 0, -h}, material, n);
}

scene::Scene floor_under_point_light(double rho, const Vec3& position, Rgb I) {
  scene::Scene s;
  s.materials.push_back(lambert_material("floor", rho));
  add_floor(s, 2.0, 0, 2);
  scene::Light l;
  l.type = scene::LightShape::point;
  l.position = position;
  l.color = I;
  s.lights = {l};
  return s;
}

scene::Scene floor_under_square_light() {
  scene::Scene s;
  s.materials.push_back(lambert_material("black", 0.0));
  add_floor(s, 2.0, 0);
  scene::Light l;
  l.type = scene::LightShape::rect;
  l.position = {0.1, 1.0, -0.1};
  l.u_axis = {1, 0, 0};
  l.v_axis = {0, 0, 1};
  l.direction = {0, -1, 0};
  l.color = Rgb{10.0};
  s.lights.push_back(l);
  return s;
}

double rect_light_irradiance(const scene::Light& l, const Vec3& p, const Vec3& n) {
  const Vec3 c = l.position, u = l.u_axis * 0.5, v = l.v_axis * 0.5;
  return l.color.r * scene::polygon_projected_solid_angle({c - u - v, c + u - v, c + u + v, c - u + v}, p, n);
}

std::vector<double> texel_means(const scene::Scene& s, const std::string& name, int resolution,
                                const std::function<double(const Vec3& p, const Vec3& n)>& f) {
  lightmap::RasterOptions options;
  options.width = options.height = resolution;
  const lightmap::LightmapTexels texels = lightmap::rasterize_lightmap(s, name, options);
  std::vector<double> out(texels.texel_count(), std::nan(""));
  for (size_t t = 0; t < texels.texel_count(); ++t) {
    double sum = 0, weight = 0;
    for (const lightmap::TexelSample& p : texels.at(t)) {
      sum += p.weight * f(p.position, p.shading_normal);
      weight += p.weight;
    }
    if (weight > 0) out[t] = sum / weight;
  }
  return out;
}

std::string equirect_exr(int width, int height, const std::function<Rgb(const Vec3& dir)>& radiance) {
  image::FloatImage img;
  img.width = width;
  img.height = height;
  img.channels = 3;
  img.channel_names = {"R", "G", "B"};
  img.pixels.resize(static_cast<size_t>(width) * height * 3);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const Rgb L = radiance(envmap::equirect_uv_to_direction((x + 0.5) / width, (y + 0.5) / height));
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = static_cast<float>(L[c]);
    }
  }
  return image::encode_exr(img);
}

lightmap::LightmapBakeInput lightmap_input(scene::Scene s, int resolution, double target_error) {
  lightmap::LightmapBakeInput in;
  in.scene = std::move(s);
  in.resolution = resolution;
  in.target_error = target_error;
  in.padding = 0;
  in.stitch_seams = false;
  in.preview = false;
  in.error_metric = lightmap::ErrorMetric::texel;
  return in;
}

const bake::BakeOutput& find_output(const lightmap::LightmapBakeResult& result, const std::string& name) {
  for (const bake::BakeOutput& o : result.outputs) {
    if (o.name == name) return o;
  }
  throw std::runtime_error("the bake has no output named " + name);
}

image::FloatImage exr_output(const lightmap::LightmapBakeResult& result, const std::string& name) {
  return image::decode_exr(find_output(result, name).bytes);
}

// ---- The bundled Cornell box (client/examples/scenes/cornell_box.py, ported line for line) ----

namespace {

using Face = std::array<Vec3, 4>;  // counter-clockwise seen from the front

Vec3 rotate_y(const Vec3& p, double degrees, const Vec3& centre) {
  const double a = degrees * kPi / 180, x = p.x - centre.x, z = p.z - centre.z;
  return {centre.x + std::cos(a) * x + std::sin(a) * z, p.y, centre.z - std::sin(a) * x + std::cos(a) * z};
}

// Five faces (no bottom) of a box standing on the floor, rotated about its vertical axis (the script's block()).
std::vector<Face> block(double cx, double cz, double sx, double sy, double sz, double degrees) {
  const double x0 = cx - sx / 2, x1 = cx + sx / 2, z0 = cz - sz / 2, z1 = cz + sz / 2;
  std::vector<Face> faces = {
      Face{Vec3{x0, sy, z1}, Vec3{x1, sy, z1}, Vec3{x1, sy, z0}, Vec3{x0, sy, z0}},  // top, +y
      Face{Vec3{x0, 0, z1}, Vec3{x1, 0, z1}, Vec3{x1, sy, z1}, Vec3{x0, sy, z1}},    // front, +z
      Face{Vec3{x1, 0, z0}, Vec3{x0, 0, z0}, Vec3{x0, sy, z0}, Vec3{x1, sy, z0}},    // back, −z
      Face{Vec3{x0, 0, z0}, Vec3{x0, 0, z1}, Vec3{x0, sy, z1}, Vec3{x0, sy, z0}},    // left, −x
      Face{Vec3{x1, 0, z1}, Vec3{x1, 0, z0}, Vec3{x1, sy, z0}, Vec3{x1, sy, z1}},    // right, +x
  };
  for (Face& f : faces)
    for (Vec3& p : f) p = rotate_y(p, degrees, {cx, 0, cz});
  return faces;
}

double as_float(double v) { return static_cast<float>(v); }  // the glTF's float32 storage
Vec3 as_float(const Vec3& v) { return {as_float(v.x), as_float(v.y), as_float(v.z)}; }

// The script's atlas() and mesh_arrays(): each face a chart scaled uniformly into a grid cell, margins between.
scene::Mesh cornell_mesh(const std::string& name, const std::vector<Face>& faces, uint32_t material) {
  const size_t n = faces.size();
  const int cols = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(n))));
  const int rows = static_cast<int>((n + cols - 1) / cols);
  const double cell_w = (1 - kMargin * (cols + 1)) / cols, cell_h = (1 - kMargin * (rows + 1)) / rows;
  double scale = INFINITY;
  for (const Face& f : faces)
    scale = std::min(scale, std::min(cell_w / length(f[1] - f[0]), cell_h / length(f[2] - f[1])));
  scene::Mesh mesh;
  mesh.name = name;
  for (size_t i = 0; i < n; ++i) {
    const Face& f = faces[i];
    const double w = length(f[1] - f[0]), h = length(f[2] - f[1]);
    const int c = static_cast<int>(i) % cols, r = static_cast<int>(i) / cols;
    const double u0 = kMargin + c * (cell_w + kMargin) + (cell_w - w * scale) / 2;
    const double v0 = kMargin + r * (cell_h + kMargin) + (cell_h - h * scale) / 2;
    const double u1 = u0 + w * scale, v1 = v0 + h * scale;
    const Vec3 normal = normalize(cross(f[1] - f[0], f[2] - f[0]));
    const uint32_t base = static_cast<uint32_t>(mesh.positions.size());
    const double corners[4][2] = {{0, 1}, {1, 1}, {1, 0}, {0, 0}};  // glTF UVs: v = 0 at the top of the image
    for (int k = 0; k < 4; ++k) {
      const double s = corners[k][0], t = corners[k][1];
      mesh.positions.push_back(as_float(f[k]));
      mesh.normals.push_back(as_float(normal));
      mesh.uv.push_back({s, t});
      mesh.lightmap_uv.push_back({as_float(u0 + s * (u1 - u0)), as_float(v0 + t * (v1 - v0))});
    }
    mesh.indices.insert(mesh.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
    mesh.material.insert(mesh.material.end(), {material, material});
  }
  return mesh;
}

}  // namespace

scene::Scene cornell_box() {
  scene::Scene s;
  auto material = [&](const std::string& name, Rgb base_color, Rgb emission = Rgb{0.0}) {
    scene::SceneMaterial m = lambert_material(name, 1.0, emission);
    m.base_color = base_color;
    s.materials.push_back(m);
    return static_cast<uint32_t>(s.materials.size() - 1);
  };
  const uint32_t white = material("white", Rgb{0.73});
  const uint32_t red = material("red", Rgb{0.63, 0.065, 0.05});
  const uint32_t green = material("green", Rgb{0.14, 0.45, 0.091});
  // glTF's emissiveFactor (1, 0.71, 0.24) times KHR_materials_emissive_strength 17.
  const uint32_t light = material("light", Rgb{0.78}, Rgb{1.0, 0.71, 0.24} * 17.0);
  auto face = [](Vec3 a, Vec3 b, Vec3 c, Vec3 d) { return std::vector<Face>{Face{a, b, c, d}}; };
  add_mesh(s, cornell_mesh("floor", face({-1, 0, 1}, {1, 0, 1}, {1, 0, -1}, {-1, 0, -1}), white));
  add_mesh(s, cornell_mesh("ceiling", face({-1, 2, -1}, {1, 2, -1}, {1, 2, 1}, {-1, 2, 1}), white));
  add_mesh(s, cornell_mesh("back_wall", face({-1, 0, -1}, {1, 0, -1}, {1, 2, -1}, {-1, 2, -1}), white));
  add_mesh(s, cornell_mesh("left_wall", face({-1, 0, 1}, {-1, 0, -1}, {-1, 2, -1}, {-1, 2, 1}), red));
  add_mesh(s, cornell_mesh("right_wall", face({1, 0, -1}, {1, 0, 1}, {1, 2, 1}, {1, 2, -1}), green));
  add_mesh(s, cornell_mesh("short_block", block(0.33, 0.37, 0.6, 0.6, 0.6, -17), white));
  add_mesh(s, cornell_mesh("tall_block", block(-0.33, -0.3, 0.6, 1.2, 0.6, 18), white));
  // Just below the ceiling so that it does not coincide with it; faces down.
  add_mesh(
      s, cornell_mesh("light", face({-0.25, 1.99, -0.25}, {0.25, 1.99, -0.25}, {0.25, 1.99, 0.25}, {-0.25, 1.99, 0.25}),
                      light));
  return s;
}

}  // namespace kiln::test
