#include "bakers/uvgen/uv_quality.h"

#include <algorithm>
#include <cmath>

#include "bakers/math/constants.h"
#include "bakers/scene/scene_check.h"
#include "bakers/uvgen/mesh_charts.h"

namespace kiln::uvgen {
namespace {

double angle(const Vec3& a, const Vec3& b) { return std::atan2(length(cross(a, b)), dot(a, b)); }
double angle(const Point2& a, const Point2& b) {
  return std::atan2(std::fabs(a.x * b.y - a.y * b.x), a.x * b.x + a.y * b.y);
}
Point2 minus(const Point2& a, const Point2& b) { return {a.x - b.x, a.y - b.y}; }

}  // namespace

void DistortionSums::add(const std::array<Vec3, 3>& p, const std::array<Point2, 3>& q) {
  const double a3 = 0.5 * length(cross(p[1] - p[0], p[2] - p[0]));
  const double a2_signed = 0.5 * ((q[1].x - q[0].x) * (q[2].y - q[0].y) - (q[2].x - q[0].x) * (q[1].y - q[0].y));
  const double a2 = std::fabs(a2_signed);
  if (!(a3 > 0) || !(a2 > 0) || !std::isfinite(a3) || !std::isfinite(a2)) return;
  // Sander et al.: the partial derivatives of the surface point along s and t (the UV axes).
  const double s1 = q[0].x, s2 = q[1].x, s3 = q[2].x, t1 = q[0].y, t2 = q[1].y, t3 = q[2].y;
  const Vec3 ss = (p[0] * (t2 - t3) + p[1] * (t3 - t1) + p[2] * (t1 - t2)) / (2 * a2_signed);
  const Vec3 st = (p[0] * (s3 - s2) + p[1] * (s1 - s3) + p[2] * (s2 - s1)) / (2 * a2_signed);
  const double l2_squared = 0.5 * (dot(ss, ss) + dot(st, st));
  area3_ += a3;
  area2_ += a2;
  stretch_ += a3 * l2_squared;
  for (int c = 0; c < 3; ++c) {
    const int n = (c + 1) % 3, m = (c + 2) % 3;
    angle_error_ += std::fabs(angle(p[n] - p[c], p[m] - p[c]) - angle(minus(q[n], q[c]), minus(q[m], q[c])));
  }
  ++triangles_;
  if (a2_signed > 0) ++positive_;
}

double DistortionSums::l2_stretch() const {
  if (triangles_ == 0) return 1;
  return std::sqrt(stretch_ / area3_) * std::sqrt(area2_ / area3_);
}

double DistortionSums::mean_angle_error_degrees() const {
  return triangles_ == 0 ? 0 : angle_error_ / (3.0 * static_cast<double>(triangles_)) * 180 / kPi;
}

UvQuality measure_uv_quality(const scene::Mesh& mesh) {
  UvQuality q;
  const size_t nv = mesh.positions.size();
  if (mesh.lightmap_uv.size() != nv) return q;
  DistortionSums sums;
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const uint32_t* i = &mesh.indices[t];
    if (i[0] >= nv || i[1] >= nv || i[2] >= nv) continue;
    const std::array<Vec3, 3> p{mesh.positions[i[0]], mesh.positions[i[1]], mesh.positions[i[2]]};
    if (!chartable(p[0], p[1], p[2])) continue;
    sums.add(p, {mesh.lightmap_uv[i[0]], mesh.lightmap_uv[i[1]], mesh.lightmap_uv[i[2]]});
  }
  q.triangles = sums.triangles();
  q.l2_stretch = sums.l2_stretch();
  q.mean_angle_error_degrees = sums.mean_angle_error_degrees();
  q.utilisation = sums.uv_area();
  q.flipped = std::min(sums.positive(), sums.triangles() - sums.positive());
  overlapping_uv_triangles(mesh, 0, q.overlaps);
  return q;
}

scene::CheckedScene check_mesh_alone(const scene::Mesh& mesh, size_t max_listed_per_kind) {
  scene::Scene one;
  one.meshes.push_back(mesh);
  one.instances.emplace_back();
  one.materials.emplace_back();
  scene::CheckOptions options;
  options.max_listed_per_kind = max_listed_per_kind;
  return scene::check_scene(one, options);
}

std::vector<std::pair<uint32_t, uint32_t>> overlapping_uv_triangles(const scene::Mesh& mesh, size_t max_pairs,
                                                                    int64_t& count) {
  const scene::CheckedScene checked = check_mesh_alone(mesh, max_pairs);
  count = checked.report.count(scene::ProblemKind::overlapping_lightmap_uv);
  std::vector<std::pair<uint32_t, uint32_t>> pairs;
  for (const scene::Problem& p : checked.report.problems) {
    if (p.kind != scene::ProblemKind::overlapping_lightmap_uv) continue;
    pairs.emplace_back(static_cast<uint32_t>(p.triangle), static_cast<uint32_t>(p.other_triangle));
  }
  return pairs;
}

}  // namespace kiln::uvgen
