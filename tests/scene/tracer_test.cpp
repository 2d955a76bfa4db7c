// The Embree tracer: hits against an independent double-precision ray–triangle test, instance transforms (normals by
// the inverse transpose), interpolated attributes, occlusion, streams, threads; and the ray offsets: no ray spawned
// off a surface finds that surface again, at grazing angles, at scales 1e-3 to 1e4 and far from the origin, and the
// same scene traced at every scale gives the same hits.
#include "bakers/scene/tracer.h"

#include <gtest/gtest.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include "bakers/math/rng.h"
#include "bakers/math/sampling.h"
#include "bakers/scene/scene_check.h"
#include "tests/scene/tracer_geometry.h"
#include "tests/support/tolerance.h"

namespace kiln::scene {
namespace {

using test::box_room;
using test::compose;
using test::scale_translate;
using test::square;
using test::uv_sphere;

constexpr double kFloatEps = 0x1.0p-24;  // unit roundoff of float: Embree's arithmetic

Scene one_mesh(Mesh m, const Transform& t = {}) {
  Scene s;
  s.materials.resize(1);
  s.meshes.push_back(std::move(m));
  s.instances.push_back(test::instance(0, t));
  return s;
}

// Independent reference: Möller–Trumbore in double. Returns t, u, v (p = (1−u−v)p0 + u p1 + v p2).
std::optional<std::array<double, 3>> reference_hit(const Vec3& o, const Vec3& d, const Vec3& p0, const Vec3& p1,
                                                   const Vec3& p2) {
  const Vec3 e1 = p1 - p0, e2 = p2 - p0, pv = cross(d, e2);
  const double det = dot(e1, pv);
  if (det == 0) return std::nullopt;
  const Vec3 tv = o - p0;
  const double u = dot(tv, pv) / det;
  const Vec3 qv = cross(tv, e1);
  const double v = dot(d, qv) / det, t = dot(e2, qv) / det;
  if (u < 0 || v < 0 || u + v > 1 || t <= 0) return std::nullopt;
  return std::array<double, 3>{t, u, v};
}

Vec3 random_unit(Pcg32& rng) { return sample_uniform_sphere({rng.uniform(), rng.uniform()}); }

// A direction at cos θ = `cos_theta` to the unit normal n (negative: below it), with a random azimuth.
Vec3 at_angle(const Vec3& n, double cos_theta, Pcg32& rng) {
  const Frame f = Frame::from_normal(n);
  const double phi = 2 * kPi * rng.uniform(), sin_theta = std::sqrt(1 - cos_theta * cos_theta);
  return (f.s * std::cos(phi) + f.t * std::sin(phi)) * sin_theta + n * cos_theta;
}

// ---------------------------------------------------------------------------------------------------------------

TEST(Tracer, HitsMatchAnIndependentDoublePrecisionTest) {
  // Random well-shaped triangles, one per scene, and rays aimed at random interior points from random directions.
  // Tolerance: Embree works in float on float vertices; t, u, v agree with the double reference to a few float
  // roundoffs relative to the scene's extent (≤ 4), so 1e-5 relative with a 1e-5 floor is ~100× that margin, far
  // below any difference a wrong formula would make.
  Pcg32 rng(7);
  int compared = 0;
  for (int k = 0; k < 200; ++k) {
    Mesh m;
    for (int i = 0; i < 3; ++i) m.positions.push_back(random_unit(rng) * 2.0);
    m.indices = {0, 1, 2};
    const Vec3 &p0 = m.positions[0], &p1 = m.positions[1], &p2 = m.positions[2];
    if (length(cross(p1 - p0, p2 - p0)) < 0.5) continue;  // slivers are the offset tests' business
    // Float-exact vertices, so the reference sees the triangle Embree sees.
    for (Vec3& p : m.positions) p = {float(p.x), float(p.y), float(p.z)};
    const Tracer tracer(one_mesh(m));
    const double bu = 0.05 + 0.9 * rng.uniform(), bv = (1 - bu) * (0.05 + 0.9 * rng.uniform());
    const Vec3 target = m.positions[0] * (1 - bu - bv) + m.positions[1] * bu + m.positions[2] * bv;
    const Vec3 origin = {float(target.x + 3 * random_unit(rng).x), float(target.y + 3 * random_unit(rng).y),
                         float(target.z + 3 * random_unit(rng).z)};
    const Vec3 d = target - origin;
    const Vec3 dir{float(d.x), float(d.y), float(d.z)};  // the ray Embree sees, exactly
    // Skip grazing incidence (cos < 0.1): float errors in u, v grow as 1/cos there; covered by the offset tests.
    if (std::fabs(dot(normalize(dir),
                      normalize(cross(m.positions[1] - m.positions[0], m.positions[2] - m.positions[0])))) < 0.1)
      continue;
    const auto ref = reference_hit(origin, dir, m.positions[0], m.positions[1], m.positions[2]);
    ASSERT_TRUE(ref.has_value());
    const auto hit = tracer.intersect({origin, dir});
    ASSERT_TRUE(hit.has_value()) << "triangle " << k;
    EXPECT_TRUE(kiln::test::close(hit->t, (*ref)[0], 1e-5, 1e-5))
        << hit->t << " " << (*ref)[0] << " u " << hit->u << " " << (*ref)[1] << " v " << hit->v << " " << (*ref)[2];
    EXPECT_TRUE(kiln::test::close(hit->u, (*ref)[1], 1e-5, 1e-5));
    EXPECT_TRUE(kiln::test::close(hit->v, (*ref)[2], 1e-5, 1e-5));
    EXPECT_TRUE(kiln::test::close(length(hit->p - target), 0, 0, 1e-4));
    const Vec3 ng = normalize(cross(m.positions[1] - m.positions[0], m.positions[2] - m.positions[0]));
    EXPECT_TRUE(kiln::test::close(dot(hit->ng, ng), 1, 1e-12));
    EXPECT_EQ(hit->front_face, dot(dir, ng) < 0);
    ++compared;
  }
  EXPECT_GT(compared, 100);
}

TEST(Tracer, AnalyticHitFrontAndBack) {
  Mesh m;
  m.positions = {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}};
  m.indices = {0, 1, 2};
  const Tracer tracer(one_mesh(m));
  // From +z (the front: (p1 − p0) × (p2 − p0) = +z) at (0.5, 0.25): t = 3, u = x/2, v = y/2. All values are exact in
  // float, so the only error is Embree's division: 1e-6 relative is a few float roundoffs.
  const auto front = tracer.intersect({{0.5, 0.25, 3}, {0, 0, -1}});
  ASSERT_TRUE(front.has_value());
  EXPECT_TRUE(kiln::test::close(front->t, 3, 1e-6));
  EXPECT_TRUE(kiln::test::close(front->u, 0.25, 1e-6));
  EXPECT_TRUE(kiln::test::close(front->v, 0.125, 1e-6));
  EXPECT_TRUE(front->front_face);
  EXPECT_EQ(front->ng, (Vec3{0, 0, 1}));
  EXPECT_EQ(front->ns, (Vec3{0, 0, 1}));  // no vertex normals: the geometric one
  const auto back = tracer.intersect({{0.5, 0.25, -2}, {0, 0, 2}});
  ASSERT_TRUE(back.has_value());
  EXPECT_TRUE(kiln::test::close(back->t, 1, 1e-6));  // t in units of |direction| = 2
  EXPECT_FALSE(back->front_face);
  EXPECT_EQ(back->ng, (Vec3{0, 0, 1}));  // ng stays on the front side
  // Misses: beside the hypotenuse, behind the origin, beyond tmax.
  EXPECT_FALSE(tracer.intersect({{1.01, 1.01, 3}, {0, 0, -1}}).has_value());
  EXPECT_FALSE(tracer.intersect({{0.5, 0.25, 3}, {0, 0, 1}}).has_value());
  EXPECT_FALSE(tracer.intersect({{0.5, 0.25, 3}, {0, 0, -1}, 2.999}).has_value());
  EXPECT_TRUE(tracer.intersect({{0.5, 0.25, 3}, {0, 0, -1}, 3.001}).has_value());
}

TEST(Tracer, InstanceTransformsAndNormalsByTheInverseTranspose) {
  // A triangle in the xy-plane with a tilted (non-unit) vertex normal, placed by rotation · non-uniform scale +
  // translation, and by a mirror. Expected values computed here from the matrices: positions by M, normals by M^-T.
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.normals = {{1, 0, 2}, {1, 0, 2}, {1, 0, 2}};
  m.indices = {0, 1, 2};
  const double c = std::cos(0.7), s = std::sin(0.7);
  Transform rot;  // about x
  rot.m = {1, 0, 0, 0, 0, c, -s, 0, 0, s, c, 0};
  Transform scale;
  scale.m = {3, 0, 0, 1, 0, 0.5, 0, -2, 0, 0, 2, 4};
  for (const bool mirror : {false, true}) {
    Transform t = compose(scale, rot);
    if (mirror) t.m[0] = -t.m[0], t.m[4] = -t.m[4], t.m[8] = -t.m[8];  // x → −x before the rest: det < 0
    const Tracer tracer(one_mesh(m, t));
    const Vec3 target = t.point(Vec3{0.25, 0.5, 0});  // barycentrics u = 0.25, v = 0.5
    const Vec3 origin = target + Vec3{0.3, 0.2, 1.0} * 5.0;
    const auto hit = tracer.intersect({origin, target - origin});
    ASSERT_TRUE(hit.has_value()) << "mirror " << mirror;
    // Float vertices and a float ray: 1e-5 is ~100 float roundoffs of these O(10) coordinates.
    EXPECT_TRUE(kiln::test::close(hit->u, 0.25, 1e-5, 1e-6));
    EXPECT_TRUE(kiln::test::close(hit->v, 0.5, 1e-5, 1e-6));
    EXPECT_TRUE(kiln::test::close(hit->t, 1.0, 1e-5));
    // M^-T n: with M = S R F (rotation first, F the optional mirror of x), M^-T = S^-1 R F since R^-T = R and
    // F^-T = F, so n' ∝ S^-1 (R (F n)).
    auto inv_t = [&](Vec3 n) {
      if (mirror) n.x = -n.x;
      const Vec3 rn{n.x, c * n.y - s * n.z, s * n.y + c * n.z};
      return normalize(Vec3{rn.x / 3, rn.y / 0.5, rn.z / 2});
    };
    const Vec3 expected_ng = inv_t({0, 0, 1});
    const Vec3 expected_ns = inv_t({1, 0, 2});
    // Normals from float vertices: ~1e-7 relative per component; 1e-6 leaves room.
    EXPECT_TRUE(kiln::test::close(dot(hit->ng, expected_ng), 1, 1e-6)) << "mirror " << mirror;
    EXPECT_TRUE(kiln::test::close(dot(hit->ns, expected_ns), 1, 1e-12)) << "mirror " << mirror;
    EXPECT_EQ(hit->front_face, dot(target - origin, expected_ng) < 0);
  }
}

TEST(Tracer, InterpolatedAttributes) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.indices = {0, 1, 2};
  m.normals = {normalize(Vec3{-1, -1, 1}), normalize(Vec3{1, 0, 1}), normalize(Vec3{0, 1, 1})};
  m.uv = {{0, 0}, {4, 0}, {0, 2}};
  m.lightmap_uv = {{0.1, 0.1}, {0.9, 0.1}, {0.1, 0.9}};
  Scene sc = one_mesh(m);
  sc.instances[0].lightmap_scale_offset = {0.5, 0.25, 0.5, 0.75};
  const Tracer tracer(sc);
  const double u = 0.2, v = 0.3, w = 0.5;
  const auto hit = tracer.intersect({{u, v, 1}, {0, 0, -1}});
  ASSERT_TRUE(hit.has_value());
  // Embree's float barycentrics: 1e-6.
  const Vec3 ns = normalize(m.normals[0] * w + m.normals[1] * u + m.normals[2] * v);
  EXPECT_TRUE(kiln::test::close(dot(hit->ns, ns), 1, 1e-6));
  EXPECT_TRUE(kiln::test::close(hit->uv.x, 4 * u, 1e-6));
  EXPECT_TRUE(kiln::test::close(hit->uv.y, 2 * v, 1e-6));
  EXPECT_TRUE(kiln::test::close(hit->lightmap_uv.x, 0.5 * (0.1 + 0.8 * u) + 0.5, 1e-6));
  EXPECT_TRUE(kiln::test::close(hit->lightmap_uv.y, 0.25 * (0.1 + 0.8 * v) + 0.75, 1e-6));

  // Normals that disagree with the winding are flipped onto the geometric side.
  for (Vec3& n : m.normals) n = -n;
  const Tracer flipped(one_mesh(m));
  const auto h2 = flipped.intersect({{u, v, 1}, {0, 0, -1}});
  ASSERT_TRUE(h2.has_value());
  EXPECT_GT(dot(h2->ns, h2->ng), 0);
  EXPECT_TRUE(kiln::test::close(dot(h2->ns, ns), 1, 1e-6));
  // Opposite normals that cancel at the hit point: the geometric normal stands in, never NaN.
  m.normals = {{1, 0, 0}, {-1, 0, 0}, {-1, 0, 0}};
  const Tracer cancel(one_mesh(m));
  const auto h3 = cancel.intersect({{0.25, 0.25, 1}, {0, 0, -1}});  // w = 0.5: n = 0.5·(1,0,0) + 0.5·(−1,0,0) = 0
  ASSERT_TRUE(h3.has_value());
  EXPECT_TRUE(is_finite(h3->ns));
}

// A flat face (every vertex normal the face normal, to float rounding) is shaded with its geometric normal exactly;
// a face whose normals are turned by 1e-3 rad (deliberate smoothing, if slight) interpolates them as before; and the
// material index of the triangle hit comes with the hit.
TEST(Tracer, FlatFacesShadeWithTheGeometricNormalAndSmoothOnesInterpolate) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {2, 0, 0}, {3, 0, 0}, {2, 1, 0}};
  m.indices = {0, 1, 2, 3, 4, 5};
  m.material = {0, 1};
  const Vec3 up{0, 0, 1};
  const Vec3 tilted = normalize(Vec3{1e-3, 0, 1});
  // Rounded to float, as an imported mesh's normals are, and a rotated copy of the flat one (not exactly +z).
  const Vec3 flat = normalize(Vec3{float(3e-8), float(-2e-8), 1.0f});
  m.normals = {flat, flat, up, up, tilted, up};
  Scene sc = one_mesh(m);
  sc.materials.resize(2);
  const Tracer tracer(sc);
  const auto a = tracer.intersect({{0.2, 0.3, 1}, {0, 0, -1}});
  ASSERT_TRUE(a.has_value());
  EXPECT_EQ(a->ns, a->ng) << "a flat face is shaded with its geometric normal";
  EXPECT_EQ(a->material, 0);
  const double u = 0.2, v = 0.3, w = 0.5;
  const auto b = tracer.intersect({{2 + u, v, 1}, {0, 0, -1}});
  ASSERT_TRUE(b.has_value());
  EXPECT_EQ(b->material, 1);
  const Vec3 ns = normalize(up * w + tilted * u + up * v);
  EXPECT_NE(b->ns, b->ng) << "a smoothed face interpolates its normals";
  // Embree's float barycentrics move the interpolated normal by ~1e-6 of the 2e-4 rad it turns: 1e-9 on the dot.
  EXPECT_NEAR(dot(b->ns, ns), 1.0, 1e-9);
  EXPECT_GT(std::acos(std::min(1.0, dot(b->ns, b->ng))), 1e-4);
}

TEST(Tracer, OcclusionAndStreamsAgreeWithSingleRays) {
  const Scene scene = box_room(4, 2, 12, 24);
  const CheckedScene checked = check_scene(scene);
  const Tracer tracer(checked.scene);
  // Two parallel walls: from the centre towards +x the room's wall is 5 away.
  EXPECT_TRUE(tracer.occluded({0, 2, 0}, {1, 0, 0}, 5.01));
  EXPECT_FALSE(tracer.occluded({0, 2, 0}, {1, 0, 0}, 4.99));
  EXPECT_TRUE(tracer.occluded({0, 2, 0}, {1, 0, 0}, INFINITY));
  Pcg32 rng(3);
  std::vector<Ray> rays;
  for (int i = 0; i < 3000; ++i)
    rays.push_back({Vec3{rng.uniform() * 8 - 4, rng.uniform() * 8 - 4, rng.uniform() * 8 - 4}, random_unit(rng),
                    rng.uniform() * 6});
  std::vector<uint8_t> occ(rays.size());
  std::vector<std::optional<HitId>> ids(rays.size());
  tracer.occluded(rays, occ);
  tracer.intersect(rays, ids);
  int occluded = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    const auto single = tracer.intersect(rays[i]);
    EXPECT_EQ(occ[i] != 0, tracer.occluded(rays[i]));
    EXPECT_EQ(occ[i] != 0, single.has_value());
    ASSERT_EQ(ids[i].has_value(), single.has_value());
    if (single) {
      EXPECT_EQ(ids[i]->instance, single->instance);
      EXPECT_EQ(ids[i]->triangle, single->triangle);
      // The stream may take another code path inside Embree: t to float precision.
      EXPECT_TRUE(kiln::test::close(ids[i]->t, single->t, 1e-6));
      const Hit full = tracer.complete(rays[i], *ids[i]);
      EXPECT_TRUE(kiln::test::close(length(full.p - single->p), 0, 0, 1e-5));
      EXPECT_EQ(ids[i]->front_face, single->front_face);
    }
    occluded += occ[i];
  }
  EXPECT_GT(occluded, 300);
  EXPECT_LT(occluded, 2700);  // both outcomes well represented

  // Concurrent queries from TBB workers give the single-threaded answers.
  std::vector<int> parallel(rays.size());
  tbb::parallel_for(size_t(0), rays.size(), [&](size_t i) {
    const auto h = tracer.intersect(rays[i]);
    parallel[i] = h ? h->instance * 100000 + h->triangle : -1;
  });
  for (size_t i = 0; i < rays.size(); ++i)
    EXPECT_EQ(parallel[i], ids[i] ? ids[i]->instance * 100000 + ids[i]->triangle : -1);
}

TEST(Tracer, RejectsUncleanScenesWithAClearMessage) {
  Mesh m;
  m.name = "tri";
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.indices = {0, 1, 5};
  try {
    const Tracer t(one_mesh(m));
    FAIL() << "accepted an index out of range";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("mesh 0 'tri' triangle 0"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("check_scene"), std::string::npos) << e.what();
  }
  m.indices = {0, 1, 2};
  EXPECT_THROW(Tracer(one_mesh(m, scale_translate(1e39, {}))), std::invalid_argument);  // beyond float range
  Scene s = one_mesh(m);
  s.instances[0].to_world.m[0] = 0;
  s.instances[0].to_world.m[5] = 0;
  EXPECT_THROW(Tracer{s}, std::invalid_argument);  // singular transform
  const Tracer empty(Scene{});
  EXPECT_FALSE(empty.intersect({{0, 0, 0}, {0, 0, 1}}).has_value());
}

// ---------------------------------------------------------------------------------------------------------------
// Ray offsets.

// The origin is a float at least `offset` off the surface on the side the ray leaves to, whatever rounding to float
// did, and not more than a float ulp of its largest coordinate beyond (the allowance for rounding, ≤ √3·2^-24 of it,
// plus the rounding itself, as much again; 2^-22 bounds both). Offsets of zero and of 1e-12 of the coordinates are
// where rounding dominates; points at 12 decades of scale, some with coordinates in the denormal range.
TEST(RayOffset, OriginIsLiftedAtLeastTheOffsetAndIsAFloat) {
  Pcg32 rng(11);
  for (int i = 0; i < 30000; ++i) {
    const double scale = i % 1000 == 0 ? 1e-40 : std::pow(10.0, rng.uniform() * 12 - 6);
    const double offset = (i % 3 == 0 ? 0.0 : i % 3 == 1 ? 1e-12 : 1e-6) * scale * rng.uniform();
    const SurfacePoint s{random_unit(rng) * scale, random_unit(rng), offset};
    const Vec3 w = random_unit(rng);
    const Vec3 o = offset_ray_origin(s, w);
    const double side = dot(w, s.ng) < 0 ? -1 : 1;
    const double lift = side * dot(o - s.p, s.ng);
    // ≥ offset, minus the double rounding of this check (1e-15 relative).
    EXPECT_GE(lift, s.offset - 1e-15 * scale) << i;
    const double m = std::max({std::fabs(s.p.x), std::fabs(s.p.y), std::fabs(s.p.z)});
    EXPECT_LE(lift, s.offset + 0x1.0p-22 * m + 0x1.0p-147) << i;
    EXPECT_EQ(o.x, double(float(o.x)));
    EXPECT_EQ(o.y, double(float(o.y)));
    EXPECT_EQ(o.z, double(float(o.z)));
  }
}

TEST(RayOffset, BoundScalesWithTheTriangleAndItsDistanceFromTheOrigin) {
  const Vec3 a{0, 0, 0}, b{1, 0, 0}, c{0.5, 0.8, 0};
  const double unit = self_intersection_offset(a, b, c, {0.5, 0.3, 0});
  for (double s : {1e-3, 1e4}) {
    // Exactly linear in a uniform scale (all terms are), up to double rounding.
    EXPECT_TRUE(
        kiln::test::close(self_intersection_offset(a * s, b * s, c * s, Vec3{0.5, 0.3, 0} * s), unit * s, 1e-12));
  }
  // Far from the origin the coordinate term dominates: ∝ the largest coordinate.
  const Vec3 far{1e4, 0, 0};
  const double moved = self_intersection_offset(a + far, b + far, c + far, Vec3{0.5, 0.3, 0} + far);
  EXPECT_GT(moved, 1e4 * kFloatEps);
  // Slivers need more: a triangle 1e-3 thin needs ~1e3× the lift of a well-shaped one of the same length.
  const double sliver = self_intersection_offset(a, b, {0.5, 1e-3, 0}, {0.5, 1e-4, 0});
  EXPECT_GT(sliver, 100 * unit);
}

// Rays spawned at grazing angles (cos = ±1e-3 to the geometric normal) off a hit on a convex mesh: leaving outwards
// they can hit nothing at all; leaving inwards they must not find their own triangle. Primary rays come from
// outside, aimed at random points inside; millions of spawned rays over all configurations.
struct Config {
  double scale;
  double shift;  // translation in units of the object's size
};

// True if no vertex of the float mesh lies in front of any triangle's plane (computed in double from the float
// vertices, with a margin of 1e-12 of the size for the double rounding of this check): the outward claim holds.
bool float_mesh_convex(const Mesh& m, const Transform& t, double size) {
  std::vector<Vec3> w;
  for (const Vec3& p : m.positions) {
    const Vec3 q = t.point(p);
    w.push_back({float(q.x), float(q.y), float(q.z)});
  }
  for (size_t k = 0; k < m.indices.size(); k += 3) {
    const Vec3 &p0 = w[m.indices[k]], &p1 = w[m.indices[k + 1]], &p2 = w[m.indices[k + 2]];
    const Vec3 n = normalize(cross(p1 - p0, p2 - p0));
    for (size_t v = 0; v < w.size(); ++v) {
      if (v == m.indices[k] || v == m.indices[k + 1] || v == m.indices[k + 2]) continue;
      if (dot(w[v] - p0, n) > 1e-12 * size) return false;
    }
  }
  return true;
}

TEST(RayOffset, NoSelfIntersectionAtGrazingAnglesOffASphereAtAnyScale) {
  const Mesh sphere = uv_sphere(24, 48);
  const Config configs[] = {{1, 0}, {1e-3, 0}, {1e4, 0}, {1e-3, 1e4}, {1e4, 1e4}, {1, 1e3}};
  constexpr int kRays = 200000;  // per configuration and direction kind: 6 × 200k × 3 queries = 3.6M rays
  for (const Config& cfg : configs) {
    const Vec3 centre = Vec3{1, 0.5, -0.7} * (cfg.shift * cfg.scale);
    const Transform t = scale_translate(cfg.scale, centre);
    ASSERT_TRUE(float_mesh_convex(sphere, t, cfg.scale)) << "scale " << cfg.scale << " shift " << cfg.shift;
    const CheckedScene checked = check_scene(one_mesh(sphere, t));
    const Tracer tracer(checked.scene);
    Pcg32 rng(1234);
    int64_t out_hits = 0, out_occluded = 0, in_self = 0, in_missed = 0, primaries = 0;
    for (int i = 0; i < kRays; ++i) {
      const Vec3 from = centre + random_unit(rng) * (3 * cfg.scale);
      const Vec3 to = centre + random_unit(rng) * (0.9 * cfg.scale * std::cbrt(rng.uniform()));
      const auto hit = tracer.intersect({from, to - from});
      if (!hit) continue;
      ++primaries;
      const Vec3 out = at_angle(hit->ng, 1e-3, rng);
      const Vec3 in = at_angle(hit->ng, -1e-3, rng);
      const Ray out_ray = spawn_ray(hit->surface(), out);
      out_occluded += tracer.occluded(out_ray);
      out_hits += tracer.intersect(out_ray).has_value();
      const auto in_hit = tracer.intersect(spawn_ray(hit->surface(), in));
      if (!in_hit)
        ++in_missed;
      else if (in_hit->instance == hit->instance && in_hit->triangle == hit->triangle)
        ++in_self;
    }
    SCOPED_TRACE(testing::Message() << "scale " << cfg.scale << ", shift " << cfg.shift);
    EXPECT_GT(primaries, kRays * 9 / 10);  // the targets are inside: nearly every primary ray hits
    EXPECT_EQ(out_occluded, 0);
    EXPECT_EQ(out_hits, 0);
    EXPECT_EQ(in_self, 0);
    // An inward ray starts inside the closed float mesh (watertight traversal): it must hit some other triangle.
    EXPECT_EQ(in_missed, 0);
  }
}

TEST(RayOffset, NoSelfIntersectionOffAPlaneEitherSideAtAnyScale) {
  // A 64×64-quad plane; hits from above; grazing rays continue above (reflection) or below (transmission) it: nothing
  // else is in the scene, so any hit is a self-intersection. The tilted plane is only tested near the origin: far
  // from it, independently rounded vertices make the float plane bumpy by more than a 1e-3 grazing angle (a
  // legitimate hit on a neighbour), see ray_offset.cpp.
  const Mesh plane = square(64);
  Transform tilt;
  const double c = std::cos(0.5), s = std::sin(0.5);
  tilt.m = {1, 0, 0, 0, 0, c, -s, 0, 0, s, c, 0};
  struct PlaneConfig {
    Transform t;
    double scale;
    Vec3 centre;
  };
  std::vector<PlaneConfig> configs;
  for (double scale : {1e-3, 1.0, 1e4}) {
    configs.push_back({scale_translate(scale, {}), scale, {}});
    configs.push_back({compose(scale_translate(scale, {}), tilt), scale, {}});
    const Vec3 far = Vec3{1e4, 1e4, -1e4} * scale;  // axis-aligned: every vertex has the same float y
    configs.push_back({scale_translate(scale, far), scale, far});
  }
  constexpr int kRays = 100000;
  for (const PlaneConfig& cfg : configs) {
    const Tracer tracer(check_scene(one_mesh(plane, cfg.t)).scene);
    const Vec3 up = normalize(cfg.t.vector({0, 1, 0}));
    Pcg32 rng(99);
    int64_t hits = 0, primaries = 0;
    for (int i = 0; i < kRays; ++i) {
      const Vec3 target = cfg.t.point({rng.uniform() * 1.8 - 0.9, 0, rng.uniform() * 1.8 - 0.9});
      const Vec3 from = target + (up * 2.0 + random_unit(rng)) * cfg.scale;
      const auto hit = tracer.intersect({from, target - from});
      if (!hit) continue;
      ++primaries;
      for (const double side : {1.0, -1.0}) {
        const Ray r = spawn_ray(hit->surface(), at_angle(hit->ng, side * 1e-3, rng));
        hits += tracer.occluded(r);
        if (i % 8 == 0) hits += tracer.intersect(r).has_value();
      }
    }
    EXPECT_GT(primaries, kRays * 9 / 10) << "scale " << cfg.scale;
    EXPECT_EQ(hits, 0) << "scale " << cfg.scale << " centre " << cfg.centre.x;
  }
}

TEST(RayOffset, ThinGapsAreNotSkipped) {
  // Two parallel planes 1e-4 of their size apart: rays leaving the lower one upwards (cos 1e-2 .. 1) must hit the
  // upper one at t = (gap − lift) / cos θ. A fixed epsilon would skip the gap at scale 1e-3 or self-intersect at
  // 1e4; the offsets scale. Tolerance on t: the lift (≤ ~1e-6 of the size) over cos θ ≥ 1e-2, i.e. ≤ 1e-4 of the
  // size, plus float rounding; 2e-4 of the size bounds both.
  for (double scale : {1e-3, 1.0, 1e4}) {
    Scene s;
    s.materials.resize(1);
    s.meshes.push_back(square(16));
    const double gap = 1e-4 * scale;
    s.instances.push_back(test::instance(0, scale_translate(scale, {})));
    s.instances.push_back(test::instance(0, scale_translate(scale, {0, gap, 0})));
    const Tracer tracer(check_scene(s).scene);
    Pcg32 rng(5);
    int wrong = 0;
    for (int i = 0; i < 20000; ++i) {
      const Vec3 target{(rng.uniform() * 1.6 - 0.8) * scale, 0, (rng.uniform() * 1.6 - 0.8) * scale};
      const auto hit = tracer.intersect({target - Vec3{0, scale, 0}, {0, 1, 0}});  // from below, hits the lower
      ASSERT_TRUE(hit.has_value());
      ASSERT_EQ(hit->instance, 0);
      const double cos_t = 1e-2 + (1 - 1e-2) * rng.uniform();
      const Vec3 w = at_angle({0, 1, 0}, cos_t, rng);
      const auto up = tracer.intersect(spawn_ray(hit->surface(), w));
      if (!up || up->instance != 1 || std::fabs(up->t - gap / cos_t) > 2e-4 * scale) ++wrong;
    }
    EXPECT_EQ(wrong, 0) << "scale " << scale;
  }
}

// The same scene (a box room [−1,1]³ with a sphere and transformed boxes) at scale s and shifted by `shift`·s: the
// same rays, scaled, hit the same triangles, and rays spawned off those hits do too (and never their own triangle).
// A ray is compared only if it is unambiguous at scale 1: four copies of it shifted sideways by η hit the same
// triangle. η is 5× the most that rounding to float can move a ray relative to the geometry in that configuration:
// each vertex and each ray origin moves by ≤ ½ ulp of the largest coordinate per coordinate (√3·½ ulp in length),
// so a ray by ≤ √3·ulp relative to the triangles (with a floor of 1e-6 for rounding inside Embree). Secondary rays
// are shifted within the surface they leave, so the copies still start on the right side of it, and lifted by η
// (their lift off the surface grows with the coordinates: ~4e-4·ulp/ε = 2e-3 for a shift of 1e4).
TEST(RayOffset, SameHitsAtEveryScaleAndPlace) {
  const Scene room = box_room(8, 3, 16, 32, 1.0);  // room [−1, 1]³
  // Flattened: this is the world-space bound's scale invariance. An instanced mesh (the room's two blocks share one)
  // adds the float ray transform's error, ~κ·ε of the coordinates, which far from the origin exceeds η; its offsets
  // are tested in tracer_instancing_test.cpp.
  TracerOptions flat;
  flat.instancing = Instancing::none;
  const Tracer reference(check_scene(room).scene, flat);
  constexpr int kRays = 20000;
  auto id = [](const std::optional<Hit>& h) { return h ? h->instance * 1000000 + h->triangle : -1; };
  // Copies of r shifted by ±η along s and t (for a ray leaving a surface: ±(n × d) and ±((n × d) × n), both in the
  // surface's plane).
  auto unambiguous = [&](const Ray& r, int expected, double eta, const Vec3* surface_normal = nullptr) {
    Frame f = Frame::from_normal(normalize(r.direction));
    if (surface_normal) {
      const Vec3 a = cross(*surface_normal, r.direction);
      // A ray along the normal: any tangent pair.
      f = length(a) > 1e-9 ? Frame{normalize(a), normalize(cross(a, *surface_normal)), *surface_normal}
                           : Frame::from_normal(*surface_normal);
    }
    for (const Vec3& side : {f.s, -f.s, f.t, -f.t})
      if (id(reference.intersect({r.origin + side * eta, r.direction, r.tmax})) != expected) return false;
    // Off a surface, the lift grows with the coordinates too (ray_offset.h): also a copy lifted by η more.
    return !surface_normal || id(reference.intersect({r.origin + f.n * eta, r.direction, r.tmax})) == expected;
  };
  struct Sample {
    Ray primary;
    std::optional<Hit> hit;
    Vec3 secondary_dir;
    std::optional<Hit> secondary;
  };
  Pcg32 rng(2024);
  std::vector<Sample> samples(kRays);
  for (Sample& smp : samples) {
    smp.primary = {Vec3{rng.uniform(), rng.uniform(), rng.uniform()} * 1.8 - Vec3{0.9, 0.9, 0.9}, random_unit(rng)};
    smp.hit = reference.intersect(smp.primary);
    ASSERT_TRUE(smp.hit.has_value());  // a closed room
    // A random direction on the side the ray arrived from, spawned off the hit.
    Vec3 w = random_unit(rng);
    if ((dot(w, smp.hit->ng) > 0) != smp.hit->front_face) w = -w;
    smp.secondary_dir = w;
    smp.secondary = reference.intersect(spawn_ray(smp.hit->surface(), w));
    ASSERT_FALSE(smp.secondary && smp.secondary->instance == smp.hit->instance &&
                 smp.secondary->triangle == smp.hit->triangle);
  }

  for (const Config& cfg : {Config{1e-3, 0}, Config{1e4, 0}, Config{1e-3, 1e4}, Config{1e4, 1e4}}) {
    const double largest = cfg.shift + 1;  // largest coordinate in units of s
    const double ulp = std::nextafterf(float(largest), INFINITY) - float(largest);
    const double eta = std::max(5 * std::sqrt(3.0) * ulp, 1e-6);
    Scene s = room;
    const Vec3 shift = Vec3{1, -1, 1} * (cfg.shift * cfg.scale);
    const Transform place = scale_translate(cfg.scale, shift);
    for (Instance& inst : s.instances) inst.to_world = compose(place, inst.to_world);
    const Tracer tracer(check_scene(s).scene, flat);
    // Expected t differences: positions move by ≤ √3·½ ulp; t changes by that over the cosine at the hit (compared
    // only where cos > 0.1) plus Embree's float t error; 8× that bound.
    int compared = 0, compared_secondary = 0, mismatches = 0, secondary_mismatches = 0, self_hits = 0, t_errors = 0;
    for (const Sample& smp : samples) {
      const Ray r{place.point(smp.primary.origin), smp.primary.direction};
      const auto hit = tracer.intersect(r);
      ASSERT_TRUE(hit.has_value());
      const auto second = tracer.intersect(spawn_ray(hit->surface(), smp.secondary_dir));
      if (second && second->instance == hit->instance && second->triangle == hit->triangle) ++self_hits;
      if (!unambiguous(smp.primary, id(smp.hit), eta)) continue;
      ++compared;
      if (id(hit) != id(smp.hit)) {
        ++mismatches;
        continue;
      }
      const double cos_hit = std::fabs(dot(hit->ng, r.direction));
      const double t_tol = 8 * (std::sqrt(3.0) * ulp * cfg.scale / std::max(cos_hit, 0.1) + kFloatEps * hit->t);
      if (cos_hit > 0.1 && std::fabs(hit->t - smp.hit->t * cfg.scale) > t_tol) ++t_errors;
      // A secondary within ~6° of its surface may leave on the other side of the shifted triangle: rounding the
      // vertices (≤ 8.5e-4 each) tilts a triangle of altitude ≥ 0.04 (the sphere's smallest here) by up to ~0.04 rad.
      if (std::fabs(dot(smp.secondary_dir, smp.hit->ng)) < 0.1) continue;
      if (!unambiguous(spawn_ray(smp.hit->surface(), smp.secondary_dir), id(smp.secondary), eta, &smp.hit->ng))
        continue;
      ++compared_secondary;
      secondary_mismatches += id(second) != id(smp.secondary);
    }
    SCOPED_TRACE(testing::Message() << "scale " << cfg.scale << ", shift " << cfg.shift << ", eta " << eta);
    EXPECT_EQ(self_hits, 0);  // over all rays, ambiguous or not
    EXPECT_EQ(mismatches, 0);
    EXPECT_EQ(secondary_mismatches, 0);
    EXPECT_EQ(t_errors, 0);
    // Not vacuous: near the origin nearly every ray is compared (secondaries: all but the 10% within |cos| < 0.1 of
    // their surface); far from it, those within η of an edge are not.
    EXPECT_GT(compared, cfg.shift == 0 ? kRays * 99 / 100 : kRays / 2);
    EXPECT_GT(compared_secondary, cfg.shift == 0 ? kRays * 85 / 100 : kRays / 3);
  }
}

TEST(RayOffset, NoShadowAcneOnASphereLitAtGrazing) {
  // A sun at grazing incidence over a sphere seen from the side: every visible point whose geometric normal faces
  // the sun (n·L > 0, down to 1e-6) must be unshadowed, since the float mesh is convex (checked). Points with
  // n·L ≤ 0 are in the sphere's own shadow by definition and are not tested.
  const Mesh sphere = uv_sphere(32, 64);
  for (const Config& cfg : {Config{1, 0}, Config{1e-3, 0}, Config{1e4, 1e3}}) {
    const Vec3 centre = Vec3{-1, 2, 0.5} * (cfg.shift * cfg.scale);
    const Transform t = scale_translate(cfg.scale, centre);
    ASSERT_TRUE(float_mesh_convex(sphere, t, cfg.scale));
    const Tracer tracer(check_scene(one_mesh(sphere, t)).scene);
    const Vec3 to_sun = normalize(Vec3{1, 0.02, 0});
    Pcg32 rng(8);
    int lit = 0, acne = 0;
    for (int i = 0; i < 400000; ++i) {
      // Camera on −z, looking at points near the terminator (x ≈ 0 on the sphere).
      const Vec3 aim = centre + Vec3{(rng.uniform() - 0.5) * 0.2, rng.uniform() * 1.8 - 0.9, 0} * cfg.scale;
      const Vec3 eye = centre + Vec3{0, 0, -4} * cfg.scale;
      const auto hit = tracer.intersect({eye, aim - eye});
      if (!hit || dot(hit->ng, to_sun) <= 0) continue;
      ++lit;
      acne += tracer.occluded(spawn_ray(hit->surface(), to_sun));
    }
    EXPECT_GT(lit, 100000);
    EXPECT_EQ(acne, 0) << "scale " << cfg.scale << " shift " << cfg.shift;
  }
}

}  // namespace
}  // namespace kiln::scene
