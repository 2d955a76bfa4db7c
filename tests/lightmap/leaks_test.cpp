// Leak handling against an analytic fake tracer (axis-aligned closed boxes with outward faces, and a one-sided
// floor): floor samples under a wall are pushed out to the side they were on, or dropped when too deep; samples in
// the open stay where they are.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "bakers/lightmap/leaks.h"
#include "bakers/lightmap/texels.h"
#include "bakers/math/constants.h"
#include "bakers/scene/ray_offset.h"

namespace kiln::lightmap {
namespace {

struct Box {
  Vec3 lo, hi;
  bool contains(const Vec3& p) const {
    return p.x > lo.x && p.x < hi.x && p.y > lo.y && p.y < hi.y && p.z > lo.z && p.z < hi.z;
  }
};

// The floor y = 0 over [-1, 1]² (front +y) and closed boxes; exact ray casts in double precision.
class FakeTracer : public RayQuery {
 public:
  std::vector<Box> boxes;
  double floor_half = 1;  // the floor is [−floor_half, floor_half]²

  std::optional<HitInfo> intersect(const Vec3& o, const Vec3& d, double tmax) const override {
    std::optional<HitInfo> best;
    const auto offer = [&](double t, bool front, Vec3 n) {
      if (t > 0 && t <= tmax && (!best || t < best->t)) best = HitInfo{t, front, n};
    };
    if (d.y != 0) {
      const double t = -o.y / d.y;
      const Vec3 p = o + d * t;
      if (std::fabs(p.x) <= floor_half && std::fabs(p.z) <= floor_half) offer(t, d.y < 0, {0, 1, 0});
    }
    for (const Box& b : boxes) {
      // Slabs: the entry is the latest of the per-axis entries, the exit the earliest of the exits.
      double t_in = -std::numeric_limits<double>::infinity(), t_out = std::numeric_limits<double>::infinity();
      int axis_in = -1, axis_out = -1;
      const double oc[3] = {o.x, o.y, o.z}, dc[3] = {d.x, d.y, d.z};
      const double lo[3] = {b.lo.x, b.lo.y, b.lo.z}, hi[3] = {b.hi.x, b.hi.y, b.hi.z};
      bool miss = false;
      for (int a = 0; a < 3; ++a) {
        if (dc[a] == 0) {
          if (oc[a] <= lo[a] || oc[a] >= hi[a]) miss = true;
          continue;
        }
        double t0 = (lo[a] - oc[a]) / dc[a], t1 = (hi[a] - oc[a]) / dc[a];
        if (t0 > t1) std::swap(t0, t1);
        if (t0 > t_in) t_in = t0, axis_in = a;
        if (t1 < t_out) t_out = t1, axis_out = a;
      }
      if (miss || t_in > t_out) continue;
      const auto axis_normal = [](int a, double s) {
        return a == 0 ? Vec3{s, 0, 0} : a == 1 ? Vec3{0, s, 0} : Vec3{0, 0, s};
      };
      if (t_in > 0) {
        offer(t_in, true, axis_normal(axis_in, dc[axis_in] > 0 ? -1.0 : 1.0));  // entering: the face faces the ray
      } else {
        offer(t_out, false, axis_normal(axis_out, dc[axis_out] > 0 ? 1.0 : -1.0));  // leaving from inside
      }
    }
    return best;
  }
};

// The floor [−scale, scale]² at y = 0 as a lightmapped quad facing +y: 32×32 texels of scale/16.
LightmapTexels floor_texels(double scale = 1) {
  scene::Scene s;
  scene::Mesh m;
  m.name = "floor";
  m.lightmap_uv = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  for (const Point2& q : m.lightmap_uv) m.positions.push_back({(2 * q.x - 1) * scale, 0, (2 * q.y - 1) * scale});
  m.indices = {0, 3, 2, 0, 2, 1};
  s.meshes.push_back(m);
  s.instances.push_back({});
  LightmapTexels t = rasterize_lightmap(s, "floor", {32, 32, 2});
  EXPECT_EQ(t.valid_count(), 32u * 32u);
  for (const TexelSample& smp : t.samples) {
    EXPECT_EQ(smp.geometric_normal, (Vec3{0, 1, 0}));
    EXPECT_NEAR(smp.texel_world_size, 0.0625 * scale, 1e-7 * scale);  // stored as a float: 2⁻²⁴ relative
  }
  return t;
}

constexpr double kTexel = 0.0625;

// The rule of leaks.h as it reads, with every ray of every probe traced to its full length: the reference that the
// early end must match exactly (the same rays up to where it stops, so the same floating-point results).
struct FullProbe {
  int back = 0;
  std::vector<std::pair<double, Vec3>> candidates;  // (t, point pushed out), every back face within the move distance
};

FullProbe full_probe(const Vec3& p, const Vec3& n, const TexelSample& s, const RayQuery& rays, const LeakOptions& o) {
  const double texel = s.texel_world_size;
  const scene::SurfacePoint surface{p, n, std::max<double>(s.ray_offset, o.origin_offset_texels * texel)};
  const Frame frame = Frame::from_normal(n);
  FullProbe out;
  for (int i = 0; i < o.rings; ++i) {
    const double cos_theta = (i + 0.5) / o.rings, sin_theta = std::sqrt(1 - cos_theta * cos_theta);
    for (int j = 0; j < o.sectors; ++j) {
      const double phi = 2 * kPi * (j + 0.5 + 0.5 * (i % 2)) / o.sectors;
      const Vec3 dir = frame.from_local({sin_theta * std::cos(phi), sin_theta * std::sin(phi), cos_theta});
      const Vec3 origin = scene::offset_ray_origin(surface, dir);
      const auto hit = rays.intersect(origin, dir, o.probe_distance_texels * texel);
      if (!hit || hit->front_face) continue;
      ++out.back;
      if (hit->t <= o.move_distance_texels * texel) {
        out.candidates.push_back({hit->t, origin + dir * hit->t + hit->geometric_normal * (o.push_texels * texel)});
      }
    }
  }
  std::stable_sort(out.candidates.begin(), out.candidates.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  return out;
}

LeakResult full_rule(const TexelSample& s, const RayQuery& rays, const LeakOptions& o) {
  const auto clear = [&](const FullProbe& f) { return f.back <= o.max_backface_fraction * o.rings * o.sectors; };
  LeakResult r;
  r.position = s.position;
  const FullProbe first = full_probe(s.position, s.geometric_normal, s, rays, o);
  const uint32_t per_probe = static_cast<uint32_t>(o.rings * o.sectors);
  r.rays = per_probe;
  if (clear(first)) return r;
  const size_t attempts = std::min<size_t>(o.max_move_attempts, first.candidates.size());
  for (size_t a = 0; a < attempts; ++a) {
    r.rays += per_probe;
    if (clear(full_probe(first.candidates[a].second, s.geometric_normal, s, rays, o))) {
      r.verdict = LeakVerdict::moved;
      r.position = first.candidates[a].second;
      return r;
    }
  }
  r.verdict = LeakVerdict::invalid;
  return r;
}

TEST(Leaks, EndingProbesEarlyKeepsEveryVerdictAndPositionOfTheFullRule) {
  // Points on and under walls of every thickness, in boxes and around them, at random normals: the early end gives
  // each the verdict and (bit for bit) the position that tracing every ray in full gives, with fewer rays.
  FakeTracer tracer;
  tracer.boxes.push_back({{-0.1, 0, -1.5}, {0.1, 1, 1.5}});     // a thin wall
  tracer.boxes.push_back({{0.35, 0, -1.5}, {0.95, 1, 1.5}});    // a thick one
  tracer.boxes.push_back({{-0.9, 0, -0.5}, {-0.5, 0.3, 0.5}});  // a low block
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> u(-1, 1);
  size_t early_rays = 0, full_rays = 0, verdicts[3] = {0, 0, 0};
  for (const LeakOptions& o : {LeakOptions{}, [] {
                                 LeakOptions few;
                                 few.max_move_attempts = 1;
                                 few.probe_distance_texels = 3;  // shorter than reaching the far wall
                                 return few;
                               }()}) {
    for (int k = 0; k < 3000; ++k) {
      TexelSample s;
      s.position = {u(rng), k % 3 == 0 ? 0.0 : 0.5 * (u(rng) + 1), u(rng)};
      s.geometric_normal = k % 3 == 0 ? Vec3{0, 1, 0} : normalize(Vec3{u(rng), u(rng), u(rng)});
      s.texel_world_size = 0.0625f;
      LeakOptions in_full = o;
      in_full.end_probes_early = false;
      const LeakResult early = resolve_leak(s, tracer, o), full = full_rule(s, tracer, o),
                       baseline = resolve_leak(s, tracer, in_full);
      SCOPED_TRACE(testing::Message() << "point " << k);
      ASSERT_EQ(early.verdict, full.verdict);
      ASSERT_EQ(baseline.verdict, full.verdict);
      EXPECT_EQ(baseline.rays, full.rays);  // the baseline for benchmarks is the rule as written, every ray in full
      if (full.verdict != LeakVerdict::invalid) {
        EXPECT_EQ(early.position, full.position);
        EXPECT_EQ(baseline.position, full.position);
      }
      early_rays += early.rays;
      full_rays += full.rays;
      ++verdicts[static_cast<int>(full.verdict)];
    }
  }
  for (size_t v : verdicts) EXPECT_GT(v, 100u);  // every verdict is exercised
  EXPECT_LT(early_rays, full_rays);
}

TEST(Leaks, OpenFloorIsClear) {
  const FakeTracer tracer;
  LightmapTexels t = floor_texels();
  const auto before = t.samples;
  const LeakReport r = fix_leaks(t, tracer, {});
  EXPECT_EQ(r.moved, 0u);
  EXPECT_EQ(r.invalidated, 0u);
  // One probe each of the 4 × 8 rays but the last three: without a back face in 29 rays, three more cannot make the
  // four that a point needs to be inside (more than 10 % of 32).
  EXPECT_EQ(r.rays, before.size() * 29u);
  for (size_t j = 0; j < before.size(); ++j) EXPECT_EQ(t.samples[j].position, before[j].position);
}

TEST(Leaks, APointInsideAClosedBoxSeesOnlyBackFaces) {
  FakeTracer tracer;
  tracer.boxes.push_back({{-1, 1, -1}, {1, 3, 1}});  // above the floor, which would be a front face below
  TexelSample s;
  s.position = {0.2, 2.1, -0.3};
  s.geometric_normal = normalize(Vec3{1, 2, 3});
  s.texel_world_size = 0.01f;
  const LeakResult r = resolve_leak(s, tracer, {});
  EXPECT_EQ(r.backface_fraction, 1.0);
  EXPECT_EQ(r.verdict, LeakVerdict::invalid);  // the walls are far beyond two texels: nowhere to move to
}

// A wall x ∈ [−h, h], y ∈ [0, 1] across the whole floor (z beyond ±1).
void check_wall(double half, bool expect_some_invalid) {
  FakeTracer tracer;
  const Box wall{{-half, 0, -1.5}, {half, 1, 1.5}};
  tracer.boxes.push_back(wall);
  LightmapTexels t = floor_texels();
  const LeakOptions options;
  const double move = options.move_distance_texels * kTexel, push = options.push_texels * kTexel;
  size_t moved = 0, invalid = 0;
  for (const TexelSample& smp : t.samples) {
    const LeakResult r = resolve_leak(smp, tracer, options);
    const double x = smp.position.x, depth = half - std::fabs(x);
    SCOPED_TRACE(testing::Message() << "sample at x = " << x);
    if (depth < 0) {
      // In the open (the nearest pattern points are 0.009 m from the wall): rays meet only its outer faces.
      EXPECT_EQ(r.verdict, LeakVerdict::clear);
      EXPECT_EQ(r.position, smp.position);
      continue;
    }
    ASSERT_NE(r.verdict, LeakVerdict::clear);
    if (r.verdict == LeakVerdict::moved) {
      ++moved;
      // Out through the side it was nearest: just in front of that face (push along its normal, exact up to the
      // rounding of the hit point, 1e-12), not inside the wall, within the move distance of where it was.
      EXPECT_FALSE(wall.contains(r.position));
      EXPECT_NEAR(r.position.x, std::copysign(half + push, x), 1e-12);
      // The rays start lifted off the floor by max(ray offset ~1e-6, 1e-4 texel = 6e-6) and rounded to float: 1e-5.
      EXPECT_LE(length(r.position - smp.position), move + push + 1e-5);
      EXPECT_GE(r.position.y, 0.0);
    } else {
      ++invalid;
      // Only a point with no back face within reach cannot move: no ray of the probe reaches a side face within
      // the move distance, i.e. deeper than about that distance (the most horizontal ring leaves at 7°).
      EXPECT_GT(depth, 0.5 * move);
    }
  }
  EXPECT_GT(moved, 0u);
  EXPECT_EQ(invalid > 0, expect_some_invalid);

  // Applied to the texels: nothing remains inside the wall, every sample under it went to its own side or away.
  const auto before = t.samples;
  const size_t valid_before = t.valid_count();
  const LeakReport r = fix_leaks(t, tracer, options);
  EXPECT_EQ(r.moved, moved);
  EXPECT_EQ(r.invalidated, invalid);
  EXPECT_EQ(t.samples.size(), before.size() - invalid);
  EXPECT_EQ(valid_before - t.valid_count(), r.texels_invalidated);
  for (const TexelSample& smp : t.samples) EXPECT_FALSE(wall.contains(smp.position + Vec3{0, 1e-9, 0}));
  // Texels whose square lies wholly deeper than the move distance keep no samples.
  for (int x = 0; x < 32; ++x) {
    const double x0 = -1 + x * kTexel, x1 = x0 + kTexel;
    const bool deep = x0 > -half + move && x1 < half - move;
    if (deep) {
      EXPECT_FALSE(t.valid(x, 10)) << "texel column " << x;
    }
  }
}

TEST(Leaks, ThinWallOnAFloorPushesTheSamplesUnderItOutToTheirOwnSide) {
  // 0.2 m thick (3.2 texels): every point under it is within two texels of a side face.
  check_wall(0.1, false);
}

TEST(Leaks, ThickWallOnAFloorInvalidatesTheSamplesDeepUnderIt) {
  // 0.6 m thick (9.6 texels): the middle is far from any side face.
  check_wall(0.3, true);
}

TEST(Leaks, TheVerdictsDoNotDependOnTheSceneScale) {
  // The same floor and wall at 10⁻³ and 10⁴ m: the rule works in texel units, so every sample gets the same verdict
  // and moves to the same place relative to the scene, up to the float rounding of ray origins (for a float tracer):
  // 2⁻²⁴ ≈ 6e-8 of coordinates ≤ 1.5 scene units, so 2e-7 relative.
  const auto run = [](double scale) {
    FakeTracer tracer;
    tracer.floor_half = scale;
    tracer.boxes.push_back({Vec3{-0.1, 0, -1.5} * scale, Vec3{0.1, 1, 1.5} * scale});
    const LightmapTexels t = floor_texels(scale);
    std::vector<LeakResult> results;
    for (const TexelSample& smp : t.samples) results.push_back(resolve_leak(smp, tracer, {}));
    return results;
  };
  const auto unit = run(1);
  size_t moved = 0;
  for (double scale : {1e-3, 1e4}) {
    const auto scaled = run(scale);
    ASSERT_EQ(scaled.size(), unit.size());
    for (size_t j = 0; j < unit.size(); ++j) {
      ASSERT_EQ(scaled[j].verdict, unit[j].verdict) << "scale " << scale << " sample " << j;
      EXPECT_LT(length(scaled[j].position / scale - unit[j].position), 2e-7) << "scale " << scale;
      moved += unit[j].verdict == LeakVerdict::moved ? 1 : 0;
    }
  }
  EXPECT_GT(moved, 0u);
}

TEST(Leaks, OptionsOutOfRangeAreRefused) {
  const FakeTracer tracer;
  TexelSample s;
  s.geometric_normal = {0, 1, 0};
  s.texel_world_size = 1;
  LeakOptions o;
  o.max_backface_fraction = 1.0;
  EXPECT_THROW(resolve_leak(s, tracer, o), std::invalid_argument);
  o = {};
  o.rings = 0;
  EXPECT_THROW(resolve_leak(s, tracer, o), std::invalid_argument);
  o = {};
  o.push_texels = 0;
  EXPECT_THROW(resolve_leak(s, tracer, o), std::invalid_argument);
}

}  // namespace
}  // namespace kiln::lightmap
