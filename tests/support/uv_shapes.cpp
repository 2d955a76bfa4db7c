#include "tests/support/uv_shapes.h"

#include <cmath>
#include <functional>

#include "bakers/math/constants.h"

namespace kiln::test {
namespace {

// A (nu + 1) × (nv + 1) grid of vertices over (u, v) ∈ [0, 1]², two triangles a cell, counter-clockwise seen from
// the side ∂f/∂u × ∂f/∂v points to; the last column and row are their own vertices (a texture seam where it wraps).
scene::Mesh parametric(int nu, int nv, const std::function<Vec3(double, double)>& f, bool normals = true) {
  scene::Mesh m;
  for (int j = 0; j <= nv; ++j) {
    for (int i = 0; i <= nu; ++i) {
      const double u = static_cast<double>(i) / nu, v = static_cast<double>(j) / nv;
      m.positions.push_back(f(u, v));
      m.uv.push_back({u, v});
      if (normals) {
        const double h = 1e-5;
        const Vec3 du = f(std::min(u + h, 1.0), v) - f(std::max(u - h, 0.0), v);
        const Vec3 dv = f(u, std::min(v + h, 1.0)) - f(u, std::max(v - h, 0.0));
        const Vec3 n = cross(du, dv);
        m.normals.push_back(length(n) > 0 ? normalize(n) : Vec3{0, 1, 0});
      }
    }
  }
  const auto at = [&](int i, int j) { return static_cast<uint32_t>(j * (nu + 1) + i); };
  for (int j = 0; j < nv; ++j) {
    for (int i = 0; i < nu; ++i) {
      m.indices.insert(m.indices.end(), {at(i, j), at(i + 1, j), at(i + 1, j + 1)});
      m.indices.insert(m.indices.end(), {at(i, j), at(i + 1, j + 1), at(i, j + 1)});
    }
  }
  return m;
}

void append(scene::Mesh& to, const scene::Mesh& from) {
  const auto base = static_cast<uint32_t>(to.positions.size());
  to.positions.insert(to.positions.end(), from.positions.begin(), from.positions.end());
  to.normals.insert(to.normals.end(), from.normals.begin(), from.normals.end());
  to.uv.insert(to.uv.end(), from.uv.begin(), from.uv.end());
  for (uint32_t i : from.indices) to.indices.push_back(base + i);
}

// An axis-aligned box of split-normal faces, outward or inward.
scene::Mesh box(Vec3 lo, Vec3 hi, bool inward) {
  scene::Mesh m;
  const Vec3 c[8] = {{lo.x, lo.y, lo.z}, {hi.x, lo.y, lo.z}, {hi.x, hi.y, lo.z}, {lo.x, hi.y, lo.z},
                     {lo.x, lo.y, hi.z}, {hi.x, lo.y, hi.z}, {hi.x, hi.y, hi.z}, {lo.x, hi.y, hi.z}};
  // Each face counter-clockwise seen from outside.
  const int faces[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 4, 7, 3}, {1, 2, 6, 5}, {0, 1, 5, 4}, {3, 7, 6, 2}};
  for (const auto& f : faces) {
    const auto base = static_cast<uint32_t>(m.positions.size());
    Vec3 n = normalize(cross(c[f[1]] - c[f[0]], c[f[2]] - c[f[0]]));
    if (inward) n = -n;
    const Point2 uv[4] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    for (int k = 0; k < 4; ++k) {
      m.positions.push_back(c[f[k]]);
      m.normals.push_back(n);
      m.uv.push_back(uv[k]);
    }
    if (inward) {
      m.indices.insert(m.indices.end(), {base, base + 2, base + 1, base, base + 3, base + 2});
    } else {
      m.indices.insert(m.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
    }
  }
  return m;
}

Vec3 on_sphere(double u, double v) {
  const double phi = 2 * kPi * u, theta = kPi * v;
  return {std::sin(theta) * std::cos(phi), std::cos(theta), -std::sin(theta) * std::sin(phi)};
}

}  // namespace

scene::Mesh uv_plane(int n, double size) {
  return parametric(n, n, [&](double u, double v) { return Vec3{(u - 0.5) * size, 0, (0.5 - v) * size}; });
}

scene::Mesh uv_cube(bool split_normals) {
  if (split_normals) return box({-0.5, -0.5, -0.5}, {0.5, 0.5, 0.5}, false);
  scene::Mesh m = box({-0.5, -0.5, -0.5}, {0.5, 0.5, 0.5}, false);
  // Weld the 24 corners into 8 and drop the normals and texture UVs.
  scene::Mesh w;
  for (uint32_t i : m.indices) {
    const Vec3& p = m.positions[i];
    uint32_t k = 0;
    while (k < w.positions.size() && !(w.positions[k] == p)) ++k;
    if (k == w.positions.size()) w.positions.push_back(p);
    w.indices.push_back(k);
  }
  return w;
}

scene::Mesh uv_torus(int major, int minor, double r_major, double r_minor) {
  return parametric(major, minor, [&](double u, double v) {
    const double a = 2 * kPi * u, b = 2 * kPi * v;
    const double r = r_major + r_minor * std::cos(b);
    return Vec3{r * std::cos(a), r_minor * std::sin(b), -r * std::sin(a)};
  });
}

scene::Mesh uv_sphere(int rings, double radius) {
  return parametric(2 * rings, rings, [&](double u, double v) { return on_sphere(u, v) * radius; });
}

scene::Mesh uv_blob(bool mirrored_lightmap) {
  // A sphere pushed out into a head (+y) and four limbs (±x arms, ±x legs), symmetric about x = 0.
  scene::Mesh m = parametric(64, 48, [](double u, double v) {
    const Vec3 d = on_sphere(u, v);
    auto lobe = [&](Vec3 axis, double width, double reach) {
      const double c = dot(d, normalize(axis));
      return c > 0 ? reach * std::exp(-(1 - c) / width) : 0.0;
    };
    const double r = 1 + lobe({0, 1, 0}, 0.08, 0.6) + lobe({1, 0.4, 0}, 0.04, 0.9) + lobe({-1, 0.4, 0}, 0.04, 0.9) +
                     lobe({0.4, -1, 0}, 0.05, 0.8) + lobe({-0.4, -1, 0}, 0.05, 0.8);
    return Vec3{d.x * r * 0.8, d.y * r, d.z * r * 0.5};
  });
  // Texture UVs that mirror: both halves (x < 0 and x > 0) map onto the same half of the texture.
  double reach_x = 0, lo_y = INFINITY, hi_y = -INFINITY;
  for (const Vec3& p : m.positions)
    reach_x = std::max(reach_x, std::fabs(p.x)), lo_y = std::min(lo_y, p.y), hi_y = std::max(hi_y, p.y);
  for (size_t i = 0; i < m.positions.size(); ++i) {
    const Vec3& p = m.positions[i];
    m.uv[i] = {0.5 * std::fabs(p.x) / reach_x + (p.z < 0 ? 0.5 : 0.0), (hi_y - p.y) / (hi_y - lo_y)};
  }
  if (mirrored_lightmap) m.lightmap_uv = m.uv;
  return m;
}

scene::Mesh uv_room() {
  scene::Mesh m = box({-2, 0, -2.5}, {2, 3, 2.5}, true);
  append(m, box({-0.8, 0.7, -0.5}, {0.8, 0.76, 0.5}, false));  // table top
  for (double x : {-0.75, 0.7})
    for (double z : {-0.45, 0.4}) append(m, box({x, 0, z}, {x + 0.05, 0.7, z + 0.05}, false));  // legs
  for (double z : {-1.0, 0.6}) {
    append(m, box({-0.25, 0.45, z}, {0.25, 0.5, z + 0.4}, false));                                       // seat
    append(m, box({-0.25, 0.5, z < 0 ? z : z + 0.35}, {0.25, 1.0, z < 0 ? z + 0.05 : z + 0.4}, false));  // back
    append(m, box({-0.22, 0, z + 0.02}, {0.22, 0.45, z + 0.38}, false));                                 // base
  }
  return m;
}

scene::Mesh uv_scan(int triangles) {
  const int rings = std::max(4, static_cast<int>(std::lround(std::sqrt(triangles / 4.0))));
  // Bumps of a few wavelengths, as a scanned stone or statue has: smooth but nowhere flat.
  scene::Mesh m = parametric(
      2 * rings, rings,
      [](double u, double v) {
        const Vec3 d = on_sphere(u, v);
        const double r = 1 + 0.08 * std::sin(7 * d.x + 1) * std::sin(5 * d.y + 2) * std::sin(6 * d.z) +
                         0.03 * std::sin(23 * d.x) * std::sin(19 * d.z + 1);
        return d * r;
      },
      false);
  m.uv.clear();  // a scan has no texture UVs
  return m;
}

std::vector<NamedMesh> uv_generated_set() {
  return {{"torus", uv_torus()},
          {"sphere", uv_sphere()},
          {"blob", uv_blob()},
          {"room", uv_room()},
          {"scan_100k", uv_scan(100000)}};
}

}  // namespace kiln::test
