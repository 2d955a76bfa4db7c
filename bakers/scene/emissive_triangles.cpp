#include "bakers/scene/emissive_triangles.h"

#include <cmath>

#include "bakers/math/constants.h"

namespace kiln::scene {

namespace {

uint64_t key(int instance, int triangle) {
  return (static_cast<uint64_t>(static_cast<uint32_t>(instance)) << 32) | static_cast<uint32_t>(triangle);
}

bool emits(const Rgb& L) { return !usable_emission(L).is_black(); }

double determinant(const Transform& t) {
  const auto& m = t.m;
  return m[0] * (m[5] * m[10] - m[6] * m[9]) - m[1] * (m[4] * m[10] - m[6] * m[8]) +
         m[2] * (m[4] * m[9] - m[5] * m[8]);
}

}  // namespace

EmissiveTriangles::EmissiveTriangles(std::vector<EmissiveTriangle> triangles) {
  std::vector<double> weights;
  for (auto& t : triangles) {
    t.Le = usable_emission(t.Le);
    if (!is_finite(t.p0) || !is_finite(t.p1) || !is_finite(t.p2) || !emits(t.Le)) continue;
    const Vec3 c = cross(t.p1 - t.p0, t.p2 - t.p0);
    const double a = 0.5 * length(c);
    if (!(a > 0) || !std::isfinite(a)) continue;  // degenerate: nothing to hit, nothing to sample
    const int index = static_cast<int>(triangles_.size());
    if (t.instance >= 0 && t.triangle >= 0) index_[key(t.instance, t.triangle)] = index;
    area_.push_back(a);
    normal_.push_back(c / (2.0 * a));
    sampling_.push_back({t.p2, t.p0 - t.p2, t.p1 - t.p2, normal_.back(), 1.0 / a, t.Le, t.two_sided});
    const double sides = t.two_sided ? 2.0 : 1.0;
    weights.push_back(a * luminance(t.Le) * sides);
    power_ += t.Le * (kPi * a * sides);
    triangles_.push_back(t);
  }
  choice_ = AliasTable(weights);
}

EmissiveTriangles EmissiveTriangles::from_scene(const Scene& scene) {
  std::vector<EmissiveTriangle> out;
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    const Instance& inst = scene.instances[i];
    if (inst.mesh < 0 || inst.mesh >= static_cast<int>(scene.meshes.size())) continue;
    const Mesh& mesh = scene.meshes[inst.mesh];
    const bool mirrored = determinant(inst.to_world) < 0;
    const size_t n_tri = mesh.indices.size() / 3;
    for (size_t t = 0; t < n_tri; ++t) {
      const size_t mat = mesh.material.empty() ? 0 : (t < mesh.material.size() ? mesh.material[t] : SIZE_MAX);
      if (mat >= scene.materials.size()) continue;
      const SceneMaterial& m = scene.materials[mat];
      if (!emits(m.emission)) continue;
      const uint32_t i0 = mesh.indices[3 * t], i1 = mesh.indices[3 * t + 1], i2 = mesh.indices[3 * t + 2];
      if (i0 >= mesh.positions.size() || i1 >= mesh.positions.size() || i2 >= mesh.positions.size()) continue;
      EmissiveTriangle e;
      e.p0 = inst.to_world.point(mesh.positions[i0]);
      e.p1 = inst.to_world.point(mesh.positions[i1]);
      e.p2 = inst.to_world.point(mesh.positions[i2]);
      if (mirrored) std::swap(e.p1, e.p2);
      e.Le = m.emission;
      e.two_sided = m.two_sided;
      e.instance = static_cast<int>(i);
      e.triangle = static_cast<int>(t);
      out.push_back(e);
    }
  }
  return EmissiveTriangles(std::move(out));
}

int EmissiveTriangles::find(int instance, int triangle) const {
  const auto it = index_.find(key(instance, triangle));
  return it == index_.end() ? -1 : it->second;
}

std::optional<LightSample> EmissiveTriangles::sample_li(const Vec3& p, const Vec3& /*n*/, Point2 u) const {
  if (sampling_.empty()) return std::nullopt;
  const AliasTable::Choice choice = choice_.sample(u.x);
  const Sampling& t = sampling_[choice.index];
  const double h = dot(p - t.p2, t.ng);
  // p on the triangle's plane (edge-on) or behind a one-sided triangle: no light from it.
  if (t.two_sided ? h == 0 : !(h > 0)) return std::nullopt;
  // Heitz 2019, "A low-distortion map between triangle and square": uniform barycentrics b0, b1 of p0, p1.
  double b0, b1;
  const double ux = choice.u_remapped, uy = u.y;
  if (ux < uy) {
    b0 = ux / 2;
    b1 = uy - b0;
  } else {
    b1 = uy / 2;
    b0 = ux - b1;
  }
  const Vec3 x = t.p2 + t.e0 * b0 + t.e1 * b1;
  const Vec3 d = x - p;
  const double dist2 = dot(d, d);
  // |ng·d| = cos θ_l · dist.
  const double c = std::fabs(dot(t.ng, d));
  // p is the sampled point itself, or sees it exactly edge-on: no light along d.
  if (!(dist2 > 0) || !(c > 0)) return std::nullopt;
  const double dist = std::sqrt(dist2);
  // One division serves both wi = d / dist and the density pmf · dist² / (A cos θ_l) = pmf · dist⁴ / (A · dist · c):
  // this runs at every path vertex.
  const double r = 1.0 / (dist * c);
  LightSample s;
  s.wi = d * (c * r);
  s.Li = t.Le;
  s.pdf = choice.pmf * t.inv_area * (dist2 * dist2) * r;
  if (!std::isfinite(s.pdf)) return std::nullopt;
  s.distance = dist;
  s.point = x;
  return s;
}

double EmissiveTriangles::pdf_li(const Vec3& p, const Vec3& /*n*/, const Vec3& wi, const LightHit& hit) const {
  if (hit.triangle < 0 || hit.triangle >= size()) return 0.0;
  const int i = hit.triangle;
  const EmissiveTriangle& t = triangles_[i];
  const Vec3& ng = normal_[i];
  const double h = dot(p - t.p0, ng);
  if (t.two_sided ? h == 0 : !(h > 0)) return 0.0;  // as in sample_li
  const Vec3 d = hit.point - p;
  const double dist2 = dot(d, d);
  const double cos_l = std::fabs(dot(ng, wi));
  if (!(cos_l > 0) || !(dist2 > 0)) return 0.0;
  const double pdf = choice_.pmf(i) * dist2 / (area_[i] * cos_l);
  return std::isfinite(pdf) ? pdf : 0.0;
}

Rgb EmissiveTriangles::Le(const Vec3& /*p*/, const Vec3& wi, const LightHit& hit) const {
  if (hit.triangle < 0 || hit.triangle >= size()) return Rgb{};
  const EmissiveTriangle& t = triangles_[hit.triangle];
  const double c = dot(normal_[hit.triangle], -wi);  // > 0: the ray arrives at the front
  return (c > 0 || (t.two_sided && c < 0)) ? t.Le : Rgb{};
}

Rgb EmissiveTriangles::power(double /*scene_radius*/) const { return power_; }

}  // namespace kiln::scene
