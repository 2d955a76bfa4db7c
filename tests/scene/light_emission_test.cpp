// Rays leaving the lights (LightSource::sample_le, scene/light_emission.h), for light tracing: a χ² test of each
// light's emitted directions against its emission distribution (Mitsuba's check per sampler), the mean weight
// against the light's power (E[Le cos θ / pdf] = ∫∫ Le cos θ dA dω = Φ), and origins on the light.
#include <gtest/gtest.h>

#include <cmath>

#include "bakers/math/constants.h"
#include "bakers/math/rng.h"
#include "bakers/scene/area_lights.h"
#include "bakers/scene/emissive_triangles.h"
#include "bakers/scene/punctual_lights.h"
#include "tests/scene/light_test_util.h"

namespace kiln::scene {
namespace {

// The emitted directions as a direction sampler: the origin's numbers drawn apart. sample_le reports no density
// (only the weight), so each draw carries the density under test and the χ² alone judges it.
test::DirectionSampler emitted(const LightSource& light, const std::function<double(const Vec3&)>& pdf) {
  return [&light, pdf, rng = std::make_shared<Pcg32>(11)](Point2 u) -> std::optional<test::DirectionDraw> {
    const auto e = light.sample_le({rng->uniform(), rng->uniform()}, u);
    if (!e) return std::nullopt;
    return test::DirectionDraw{e->direction, pdf(e->direction)};
  };
}

// χ² of the directions against `pdf`.
void expect_directions(const LightSource& light, const std::function<double(const Vec3&)>& pdf, const Vec3& axis,
                       const std::string& what) {
  test::DirectionChi2Options o;
  o.axis = axis;
  o.test_count = 5;
  const test::DirectionChi2Result r = test::direction_chi2(emitted(light, pdf), pdf, o);
  EXPECT_TRUE(r.passed) << what << ": " << r.details;
}

// The mean weight per channel over n rays against the power, within 5 standard errors of the mean (weights that do
// not vary, as a Lambertian emitter's, must match to rounding).
void expect_power(const LightSource& light, const std::string& what, int n = 200000) {
  Pcg32 rng(3);
  Rgb sum, sum2;
  for (int i = 0; i < n; ++i) {
    const auto e = light.sample_le({rng.uniform(), rng.uniform()}, {rng.uniform(), rng.uniform()});
    if (!e) continue;
    sum += e->weight;
    sum2 += e->weight * e->weight;
  }
  const Rgb power = light.power(1.0);
  for (int c = 0; c < 3; ++c) {
    const double mean = sum[c] / n, var = std::max(0.0, sum2[c] / n - mean * mean);
    EXPECT_NEAR(mean, power[c], 5 * std::sqrt(var / n) + 1e-9 * power[c]) << what << " channel " << c;
  }
}

TEST(LightEmission, RectLightEmitsCosineWeightedFromItsFront) {
  const RectLight rect({0, 1, 0}, {0.5, 0, 0}, {0, 0, 0.3}, {0, -1, 0}, Rgb{2, 1, 0.5}, false);
  expect_directions(
      rect, [](const Vec3& w) { return std::max(0.0, -w.y) * kInvPi; }, {0, -1, 0}, "rect");
  expect_power(rect, "rect");
  Pcg32 rng(5);
  for (int i = 0; i < 1000; ++i) {
    const auto e = rect.sample_le({rng.uniform(), rng.uniform()}, {rng.uniform(), rng.uniform()});
    ASSERT_TRUE(e);
    EXPECT_NEAR(e->origin.y, 1.0, 1e-12);
    EXPECT_LE(std::fabs(e->origin.x), 0.25 + 1e-12);
    EXPECT_LE(std::fabs(e->origin.z), 0.15 + 1e-12);
    EXPECT_LT(e->direction.y, 0.0) << "one-sided: downwards only";
  }
}

TEST(LightEmission, TwoSidedDiskEmitsHalfFromEachSide) {
  const DiskLight disk({0, 1, 0}, {0, 1, 0}, 0.4, Rgb{1.0}, true);
  expect_directions(
      disk, [](const Vec3& w) { return std::fabs(w.y) * kInvPi / 2; }, {0, 1, 0}, "disk");
  expect_power(disk, "disk");
}

TEST(LightEmission, PointLightEmitsUniformly) {
  const PointLight point({0, 1, 0}, Rgb{3.0, 2.0, 1.0});
  expect_directions(
      point, [](const Vec3&) { return kInv4Pi; }, {0, 0, 1}, "point");
  expect_power(point, "point");
}

// The spot's rays are uniform in its outer cone and weighted by the falloff: the directions against 1/Ω inside the
// cone, the weights' mean against its power (which integrates the falloff).
TEST(LightEmission, SpotLightEmitsInItsConeWeightedByItsFalloff) {
  const double inner = 0.3, outer = 0.7;
  const SpotLight spot({0, 1, 0}, {0, -1, 0}, Rgb{5.0}, inner, outer);
  const double omega = 2 * kPi * (1 - std::cos(outer));
  expect_directions(
      spot, [&](const Vec3& w) { return -w.y >= std::cos(outer) ? 1 / omega : 0.0; }, {0, -1, 0}, "spot");
  expect_power(spot, "spot");
}

// Two triangles of different areas and emission, one two-sided: chosen by power, each emitting from its sides.
TEST(LightEmission, EmissiveTrianglesEmitByPower) {
  EmissiveTriangle a{{0, 1, 0}, {1, 1, 0}, {0, 1, 1}, Rgb{1.0}, false};
  EmissiveTriangle b{{0, 0, 0}, {0.5, 0, 0}, {0, 0, 0.5}, Rgb{4.0}, true};
  const EmissiveTriangles tris({a, b});
  expect_power(tris, "emissive triangles");
  Pcg32 rng(9);
  int from_a = 0, below_b = 0, n = 20000;
  for (int i = 0; i < n; ++i) {
    const auto e = tris.sample_le({rng.uniform(), rng.uniform()}, {rng.uniform(), rng.uniform()});
    ASSERT_TRUE(e);
    EXPECT_GT(e->offset, 0.0) << "triangles are scene geometry: rays leave them lifted";
    EXPECT_GT(dot(e->direction, e->ng), 0.0);
    if (e->origin.y == 1.0) {
      ++from_a;
      EXPECT_LT(e->direction.y, 0.0) << "a is one-sided, its front ((p1 − p0) × (p2 − p0)) facing down";
    } else if (e->direction.y < 0) {
      ++below_b;
    }
  }
  // Powers: a = π·1·0.5 = π/2, b = π·4·0.125·2 = π: a is chosen 1/3 of the time; b's back side half of the rest.
  // 5 binomial standard errors.
  EXPECT_NEAR(from_a / double(n), 1.0 / 3, 5 * std::sqrt(2.0 / 9 / n));
  EXPECT_NEAR(below_b / double(n), 1.0 / 3, 5 * std::sqrt(2.0 / 9 / n));
}

}  // namespace
}  // namespace kiln::scene
