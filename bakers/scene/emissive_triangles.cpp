#include "bakers/scene/emissive_triangles.h"

#include <cmath>
#include <cstdint>

#include "bakers/math/constants.h"
#include "bakers/scene/ray_offset.h"
#include "bakers/scene/transform_determinant.h"

namespace kiln::scene {

namespace {

bool emits(const Rgb& L) { return !usable_emission(L).is_black(); }

}  // namespace

EmissiveTriangles::EmissiveTriangles(std::vector<EmissiveTriangle> triangles) {
  std::vector<double> weights;
  for (auto& t : triangles) {
    t.Le = usable_emission(t.Le);
    if (!is_finite(t.p0) || !is_finite(t.p1) || !is_finite(t.p2) || !emits(t.Le)) continue;
    const Vec3 c = cross(t.p1 - t.p0, t.p2 - t.p0);
    const double a = 0.5 * length(c);
    if (!(a > 0) || !std::isfinite(a)) continue;  // degenerate: nothing to hit, nothing to sample
    area_.push_back(a);
    sampling_.push_back({t.p2, t.p0 - t.p2, t.p1 - t.p2, c / (2.0 * a), 1.0 / a, t.Le, t.two_sided});
    const double sides = t.two_sided ? 2.0 : 1.0;
    weights.push_back(a * luminance(t.Le) * sides);
    power_ += t.Le * (kPi * a * sides);
    triangles_.push_back(t);
  }
  choice_ = AliasTable(weights);
  // find()'s table: the span of each instance's emissive triangles first, then their indices.
  for (size_t i = 0; i < triangles_.size(); ++i) {
    const EmissiveTriangle& t = triangles_[i];
    if (t.instance < 0 || t.triangle < 0) continue;
    if (index_.size() <= static_cast<size_t>(t.instance)) index_.resize(t.instance + 1);
    InstanceIndex& x = index_[t.instance];
    if (x.index.empty()) {
      x.first = t.triangle;
      x.index.assign(1, -1);
    } else if (t.triangle < x.first) {
      x.index.insert(x.index.begin(), static_cast<size_t>(x.first - t.triangle), -1);
      x.first = t.triangle;
    } else if (static_cast<size_t>(t.triangle - x.first) >= x.index.size()) {
      x.index.resize(static_cast<size_t>(t.triangle - x.first) + 1, -1);
    }
    x.index[t.triangle - x.first] = static_cast<int>(i);
  }
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
  if (instance < 0 || static_cast<size_t>(instance) >= index_.size()) return -1;
  const InstanceIndex& x = index_[instance];
  const int64_t k = static_cast<int64_t>(triangle) - x.first;
  return k >= 0 && k < static_cast<int64_t>(x.index.size()) ? x.index[k] : -1;
}

std::optional<LightSample> EmissiveTriangles::sample_li(const Vec3& p, const Vec3& /*n*/, Point2 u) const {
  return sample(p, u);
}

double EmissiveTriangles::pdf_li(const Vec3& p, const Vec3& /*n*/, const Vec3& wi, const LightHit& hit) const {
  if (hit.triangle < 0 || hit.triangle >= size()) return 0.0;
  const int i = hit.triangle;
  const EmissiveTriangle& t = triangles_[i];
  const Vec3& ng = sampling_[i].ng;
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
  const double c = dot(sampling_[hit.triangle].ng, -wi);  // > 0: the ray arrives at the front
  return (c > 0 || (t.two_sided && c < 0)) ? t.Le : Rgb{};
}

Rgb EmissiveTriangles::power(double /*scene_radius*/) const { return power_; }

// ---- Light tracing ----

std::optional<LightEmission> EmissiveTriangles::sample_le(Point2 u_position, Point2 u_direction) const {
  if (sampling_.empty()) return std::nullopt;
  const AliasTable::Choice choice = choice_.sample(u_position.x);
  const Sampling& t = sampling_[choice.index];
  // Uniform barycentrics by the square-to-triangle map of sample() (Heitz 2019).
  const double ux = choice.u_remapped, uy = u_position.y;
  const double a = std::min(ux, uy), b = std::max(ux, uy);
  const double b0 = ux < uy ? a / 2 : b - a / 2, b1 = ux < uy ? b - a / 2 : a / 2;
  LightEmission e;
  e.origin = t.p2 + t.e0 * b0 + t.e1 * b1;
  const EmissiveTriangle& tri = triangles_[choice.index];
  e.offset = self_intersection_offset(tri.p0, tri.p1, tri.p2, e.origin);
  const std::optional<double> factor = lambertian_emission(t.ng, t.two_sided, u_direction, e);
  if (!factor) return std::nullopt;
  // Le cos θ / (pmf · 1/A · cos θ/π · p(side)).
  e.weight = t.Le * (*factor / (choice.pmf * t.inv_area));
  return e;
}

}  // namespace kiln::scene
