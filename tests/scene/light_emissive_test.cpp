// Emissive triangles: built from a scene's emissive materials (world space, mirrored instances, skipped bad input),
// chosen by power, sampled by area; irradiance against Lambert's formula and sample_li against pdf_li by χ².
#include "bakers/scene/emissive_triangles.h"

#include <gtest/gtest.h>

#include <cmath>

#include "bakers/scene/polygon_irradiance.h"
#include "tests/scene/light_test_util.h"
#include "tests/support/tolerance.h"

namespace kiln::scene {
namespace {

// Two triangles facing down (−Y) at y = 1 and one smaller, brighter, two-sided one tilted at the side.
std::vector<EmissiveTriangle> three_triangles() {
  return {
      {{0, 1, 0}, {1, 1, 0}, {1, 1, 1}, Rgb{2, 2, 2}, false, -1, -1},
      {{0, 1, 0}, {1, 1, 1}, {0, 1, 1}, Rgb{2, 2, 2}, false, -1, -1},
      {{-1, 0.5, 0}, {-1, 1.5, 0}, {-1, 0.5, 0.5}, Rgb{10, 5, 1}, true, -1, -1},
  };
}

TEST(EmissiveTriangles, FrontSidesAndPower) {
  const EmissiveTriangles tris(three_triangles());
  ASSERT_EQ(tris.size(), 3);
  // (p1 − p0) × (p2 − p0) of the first two is −Y: they face the floor.
  EXPECT_TRUE(test::close(tris.area(0), 0.5, 1e-15));
  EXPECT_TRUE(test::close(tris.area(2), 0.25, 1e-15));
  // Power: π L A per emitting side.
  const double expected_r = kPi * (2 * 0.5 * 2 + 10 * 0.25 * 2);
  EXPECT_TRUE(test::close(tris.power(1).r, expected_r, 1e-14));
  // Choice by area × luminance × sides.
  const double w0 = 0.5 * 2, w2 = 0.25 * luminance(Rgb{10, 5, 1}) * 2;
  EXPECT_TRUE(test::close(tris.pmf(2), w2 / (2 * w0 + w2), 1e-14));
  // Le: front side only for the one-sided, both for the two-sided.
  LightHit hit;
  hit.triangle = 0;
  EXPECT_EQ(tris.Le({}, {0, 1, 0}, hit).r, 2.0);  // a ray going up reaches the down-facing front
  EXPECT_TRUE(tris.Le({}, {0, -1, 0}, hit).is_black());
  hit.triangle = 2;
  EXPECT_EQ(tris.Le({}, {1, 0, 0}, hit).g, 5.0);
  EXPECT_EQ(tris.Le({}, {-1, 0, 0}, hit).g, 5.0);
}

TEST(EmissiveTriangles, IrradianceMatchesLambertsFormula) {
  const auto list = three_triangles();
  const EmissiveTriangles tris(list);
  struct Case {
    Vec3 p, n;
  };
  const Case cases[] = {
      {{0.5, 0, 0.5}, {0, 1, 0}}, {{-0.2, 0.2, 0.3}, normalize(Vec3{-1, 1, 0})}, {{0.3, 0.95, 0.6}, {0, 1, 0}}};
  uint64_t seed = 40;
  for (const Case& c : cases) {
    for (int channel : {0, 2}) {
      double exact = 0;
      for (const auto& t : list) {
        // One-sided triangles light only their front half-space.
        const double h = dot(c.p - t.p0, normalize(cross(t.p1 - t.p0, t.p2 - t.p0)));
        if (t.two_sided ? h == 0 : !(h > 0)) continue;
        exact += t.Le[channel] * polygon_projected_solid_angle({t.p0, t.p1, t.p2}, c.p, c.n);
      }
      const auto e = test::estimate_irradiance(tris, c.p, c.n, 200000, ++seed, channel);
      ASSERT_TRUE(e.all_finite);
      // 5 standard errors of the estimator (false failure ~1 in 1.7 million); Lambert's formula is exact.
      EXPECT_NEAR(e.mean, exact, 5 * e.standard_error + 1e-12)
          << "p = (" << c.p.x << ", " << c.p.y << ", " << c.p.z << "), channel " << channel;
    }
  }
}

TEST(EmissiveTriangles, SamplingMatchesPdfLi) {
  // pdf_li needs the triangle a ray hits: found by intersecting the three triangles.
  const auto list = three_triangles();
  const EmissiveTriangles tris(list);
  const auto hit_of = [&](const Vec3& p, const Vec3& w) { return test::intersect_triangles(tris, p, w); };
  const Vec3 p{0.2, 0.1, 0.4}, n{0, 1, 0};
  test::DirectionChi2Options o;
  o.axis = normalize(Vec3{0.0, 1, 0.0});
  o.theta_max = kPi / 2 + 0.3;  // all three triangles are within 107° of +Y from p
  o.n_theta = 24;
  o.n_phi = 48;
  o.samples = 300000;
  o.seed = 77;
  const auto r = test::direction_chi2(
      test::light_sampler_at(tris, p, n), [&](const Vec3& w) { return tris.pdf_li(p, n, w, hit_of(p, w)); }, o);
  EXPECT_TRUE(r.passed) << r.details;
  // ∫ pdf over the cells = 1 − P(failed): from p every triangle is lit on the side p is on (the first two face
  // down at y = 1 > p.y; the third is two-sided), so nothing fails. Quadrature of the outlines: ~1e-5 (see
  // light_area_test), allowed 1e-4.
  EXPECT_EQ(r.failures, 0);
  EXPECT_NEAR(r.pdf_integral, 1.0, 1e-4) << r.details;
}

// find() against the triangles' own provenance, for emitters scattered sparsely (and out of order) through
// instances, some instances emitting nothing.
TEST(EmissiveTriangles, FindsEveryEmitterByInstanceAndTriangle) {
  std::vector<EmissiveTriangle> in;
  Pcg32 rng(3);
  for (int k = 0; k < 200; ++k) {
    EmissiveTriangle t;
    t.p0 = {0, 0, 0};
    t.p1 = {1, 0, 0};
    t.p2 = {0, 1, 0};
    t.Le = Rgb{1.0};
    t.instance = 2 * static_cast<int>(rng.uniform() * 5);  // odd instances emit nothing
    t.triangle = static_cast<int>(rng.uniform() * 1000);
    in.push_back(t);
  }
  const EmissiveTriangles tris(in);
  for (int i = 0; i < tris.size(); ++i) {
    const EmissiveTriangle& t = tris.triangle(i);
    const int found = tris.find(t.instance, t.triangle);
    ASSERT_GE(found, 0);
    // The same triangle given twice: find() returns the last, which is the same place.
    EXPECT_EQ(tris.triangle(found).instance, t.instance);
    EXPECT_EQ(tris.triangle(found).triangle, t.triangle);
  }
  for (int instance = 1; instance < 10; instance += 2) EXPECT_EQ(tris.find(instance, 0), -1);
}

TEST(EmissiveTriangles, FromSceneTransformsAndSkipsBadInput) {
  Scene scene;
  scene.materials.resize(2);
  scene.materials[1].emission = Rgb{1, 2, 3};
  Mesh quad;
  quad.name = "quad";
  quad.positions = {{0, 0, 0}, {1, 0, 0}, {1, 0, 1}, {0, 0, 1}, {std::nan(""), 0, 0}};
  // Triangle 0 emits; triangle 1 uses the black material; triangle 2 has an index out of range; triangle 3 a NaN
  // vertex; triangle 4 is degenerate.
  quad.indices = {0, 2, 1, 0, 3, 2, 0, 1, 9, 0, 1, 4, 0, 1, 1};
  quad.material = {1, 0, 1, 1, 1};
  scene.meshes.push_back(quad);
  Instance a;
  a.mesh = 0;
  a.to_world.m = {2, 0, 0, 10, 0, 1, 0, 5, 0, 0, 1, 0};  // scale x by 2, translate (10, 5, 0)
  Instance mirrored = a;
  mirrored.to_world.m = {-1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};  // mirror x
  scene.instances = {a, mirrored};
  const EmissiveTriangles tris = EmissiveTriangles::from_scene(scene);
  ASSERT_EQ(tris.size(), 2);  // one triangle per instance survives
  const int i0 = tris.find(0, 0), i1 = tris.find(1, 0);
  ASSERT_GE(i0, 0);
  ASSERT_GE(i1, 0);
  EXPECT_EQ(tris.find(0, 1), -1);   // black material
  EXPECT_EQ(tris.find(0, 2), -1);   // index out of range
  EXPECT_EQ(tris.find(0, 3), -1);   // NaN vertex
  EXPECT_EQ(tris.find(0, 4), -1);   // degenerate
  EXPECT_EQ(tris.find(0, -1), -1);  // no such triangle or instance
  EXPECT_EQ(tris.find(0, 1 << 30), -1);
  EXPECT_EQ(tris.find(-1, 0), -1);
  EXPECT_EQ(tris.find(2, 0), -1);
  EXPECT_EQ(tris.triangle(i0).p1, (Vec3{12, 5, 1}));
  EXPECT_TRUE(test::close(tris.area(i0), 1.0, 1e-15));  // 0.5 scaled by 2 in x
  // Object-space normal of (0, 2, 1): (1,0,1) × (1,0,0) = (0, 1, 0): front is +Y. Both instances (one mirrored)
  // must keep +Y as the front: a ray going down (−Y) reaches the front.
  for (int i : {i0, i1}) {
    LightHit hit;
    hit.triangle = i;
    EXPECT_EQ(tris.Le({}, {0, -1, 0}, hit).b, 3.0) << i;
    EXPECT_TRUE(tris.Le({}, {0, 1, 0}, hit).is_black()) << i;
  }
  // Empty containers sample nothing.
  const EmissiveTriangles none(std::vector<EmissiveTriangle>{});
  EXPECT_FALSE(none.sample_li({}, {0, 1, 0}, {0.5, 0.5}));
  EXPECT_TRUE(none.power(1).is_black());
}

TEST(EmissiveTriangles, SingularCasesStayFinite) {
  const EmissiveTriangles tris(three_triangles());
  // p on the plane of the first two (y = 1), inside and outside them; p at a vertex; p behind.
  for (const Vec3& p : {Vec3{0.5, 1, 0.2}, Vec3{3, 1, 3}, Vec3{0, 1, 0}, Vec3{0.5, 2, 0.5}, Vec3{-1, 0.5, 0}}) {
    Pcg32 rng(1);
    for (int k = 0; k < 1000; ++k) {
      const auto s = tris.sample_li(p, {0, 1, 0}, {rng.uniform(), rng.uniform()});
      if (!s) continue;
      ASSERT_TRUE(is_finite(s->wi) && s->Li.is_finite() && std::isfinite(s->pdf) && s->pdf > 0 &&
                  std::isfinite(s->distance));
    }
  }
  LightHit bad;
  bad.triangle = 17;
  EXPECT_EQ(tris.pdf_li({}, {0, 1, 0}, {0, 1, 0}, bad), 0.0);
  EXPECT_TRUE(tris.Le({}, {0, 1, 0}, bad).is_black());
}

}  // namespace
}  // namespace kiln::scene
