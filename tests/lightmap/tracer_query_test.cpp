// Leak handling through the real Embree tracer: a closed wall box standing on a lightmapped floor. Floor samples
// under the wall end up outside it on their own side, or are dropped; the others stay. A two-sided wall is no
// inside at all.
#include <gtest/gtest.h>

#include <cmath>

#include "bakers/lightmap/leaks.h"
#include "bakers/lightmap/texels.h"
#include "bakers/lightmap/tracer_query.h"
#include "bakers/scene/scene_check.h"
#include "bakers/scene/tracer.h"

namespace kiln::lightmap {
namespace {

// A closed box with outward-facing triangles (counter-clockwise seen from outside), four vertices per face.
scene::Mesh box_mesh(const Vec3& lo, const Vec3& hi) {
  scene::Mesh m;
  m.name = "wall";
  const Vec3 d = hi - lo;
  const Vec3 X{d.x, 0, 0}, Y{0, d.y, 0}, Z{0, 0, d.z};
  // (corner, e1, e2) with e1 × e2 along the outward normal.
  const Vec3 faces[6][3] = {{Vec3{hi.x, lo.y, lo.z}, Y, Z}, {lo, Z, Y}, {Vec3{lo.x, hi.y, lo.z}, Z, X}, {lo, X, Z},
                            {Vec3{lo.x, lo.y, hi.z}, X, Y}, {lo, Y, X}};
  for (const auto& f : faces) {
    const uint32_t base = static_cast<uint32_t>(m.positions.size());
    m.positions.insert(m.positions.end(), {f[0], f[0] + f[1], f[0] + f[1] + f[2], f[0] + f[2]});
    m.indices.insert(m.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
  }
  return m;
}

struct WallScene {
  scene::Scene scene;  // cleaned
  scene::Tracer tracer;
  explicit WallScene(double half, bool two_sided) : scene(make(half, two_sided)), tracer(scene) {}

  static scene::Scene make(double half, bool two_sided) {
    scene::Scene s;
    scene::Mesh floor;
    floor.name = "floor";
    floor.lightmap_uv = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    for (const Point2& q : floor.lightmap_uv) floor.positions.push_back({2 * q.x - 1, 0, 2 * q.y - 1});
    floor.indices = {0, 3, 2, 0, 2, 1};  // front +y
    s.meshes.push_back(floor);
    s.meshes.push_back(box_mesh({-half, 0, -1.5}, {half, 1, 1.5}));
    s.meshes[1].material.assign(12, 1);
    s.materials.resize(2);
    s.materials[1].two_sided = two_sided;
    s.instances.resize(2);
    s.instances[1].mesh = 1;
    s.instances[1].bake = false;
    scene::CheckedScene checked = scene::check_scene(s);
    // The one thing to say: the wall has no lightmap UVs (it only casts shadows).
    EXPECT_EQ(checked.report.total(), checked.report.count(scene::ProblemKind::no_lightmap_uv))
        << checked.report.summary();
    return checked.scene;
  }
};

TEST(TracerQuery, FloorSamplesUnderAWallLeaveItOnTheirOwnSide) {
  constexpr double kHalf = 0.1;  // 3.2 texels of 1/16 m thick: every point under it is near a side
  const WallScene w(kHalf, false);
  LightmapTexels t = rasterize_lightmap(w.scene, "floor", {32, 32, 2});
  ASSERT_EQ(t.valid_count(), 32u * 32u);
  const auto before = t.samples;
  const LeakReport r = fix_leaks(t, TracerRayQuery(w.tracer, w.scene), {});
  EXPECT_GT(r.moved, 0u);
  EXPECT_EQ(r.invalidated, 0u);
  ASSERT_EQ(t.samples.size(), before.size());
  for (size_t j = 0; j < before.size(); ++j) {
    const double x0 = before[j].position.x, x1 = t.samples[j].position.x;
    SCOPED_TRACE(testing::Message() << "sample at x = " << x0);
    if (std::fabs(x0) > kHalf) {
      EXPECT_EQ(t.samples[j].position, before[j].position);  // in the open: untouched
    } else {
      // Moved out through the side face it was nearest, on its own side of the wall: |x| ≥ half (the push is
      // 1/100 texel = 6e-4 m, far above the float rounding of the hit point, ~1e-7 m).
      EXPECT_EQ(std::signbit(x1), std::signbit(x0));
      EXPECT_GT(std::fabs(x1), kHalf);
    }
  }
}

TEST(TracerQuery, TwoSidedWallsHaveNoInside) {
  const WallScene w(0.1, true);
  LightmapTexels t = rasterize_lightmap(w.scene, "floor", {32, 32, 2});
  const LeakReport r = fix_leaks(t, TracerRayQuery(w.tracer, w.scene), {});
  EXPECT_EQ(r.moved, 0u);
  EXPECT_EQ(r.invalidated, 0u);
}

}  // namespace
}  // namespace kiln::lightmap
