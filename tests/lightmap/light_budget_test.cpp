// The light-tracing budget (bakers/lightmap/light_budget.h): the number of rays from the lights that minimises the
// bake's modelled time, against the closed form for one kind of texel, and its choice to let texels that rays serve
// badly gather rather than buy rays for them.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "bakers/lightmap/light_budget.h"

namespace kiln::lightmap {
namespace {

constexpr double kTarget = 0.04;
// Costs in rays traced, about the Cornell box's: a ray from the lights with its reflections, a direct estimate, a
// full one.
constexpr double kCostPerRay = 11.5;
constexpr GatherCosts kCosts{6.9, 22.6};

// A texel whose estimates of the direct light vary by v, whose term's variance is c/N at N rays, indirect light y.
TracedTexel texel(double v, double c, double y) {
  TracedTexel x;
  x.v = v;
  x.c = c;
  x.y = y;
  x.min_rays = 0;
  return x;
}

// For T texels alike, a·N + T·b·v / (τ² − c/N) is least where N·τ² − c = √(T·b·v·c / a).
double closed_form(double texels, const TracedTexel& x) {
  const double target2 = kTarget * kTarget;
  return (x.c + std::sqrt(texels * kCosts.direct * x.v * x.c / kCostPerRay)) / target2;
}

// The budget searches a geometric grid of ratio 1.05 and the time is flat about its minimum: within a step.
constexpr double kGridStep = 1.05;

TEST(LightBudget, OneKindOfTexelGetsTheClosedFormsRays) {
  // About the Cornell box atlas at target 0.04: 40,000 texels, ~2 M rays.
  const TracedTexel x = texel(0.02, 2e3, 0.5);
  const std::vector<TracedTexel> texels(40000, x);
  const double expected = closed_form(40000, x);
  const double rays = best_light_rays(texels, kTarget, 1000, kCostPerRay, kCosts);
  EXPECT_GT(rays, expected / kGridStep);
  EXPECT_LT(rays, expected * kGridStep);
  EXPECT_FALSE(gathers_instead(x, rays, kTarget)) << "the texels stay traced at the rays chosen";
}

TEST(LightBudget, TexelsThatRaysServeBadlyGatherInsteadOfBuyingRays) {
  // The Cornell box baked one lightmap per object: the 0.5 m light patch at a wall's resolution has texels of 1/16
  // the area, 16 times fewer deposits and so 16 times the variance per ray. Buying rays for them would multiply the
  // rays by 16; they gather instead, and the rays stay those of the walls.
  const TracedTexel wall = texel(0.02, 2e3, 0.5);
  const TracedTexel patch = texel(0.02, 16 * 2e3, 0.5);
  std::vector<TracedTexel> texels(40000, wall);
  texels.insert(texels.end(), 800, patch);
  const double rays = best_light_rays(texels, kTarget, 1000, kCostPerRay, kCosts);
  const double walls_alone = closed_form(40000, wall);
  EXPECT_LT(rays, 1.2 * walls_alone);
  EXPECT_GT(rays, walls_alone / 1.2);
  EXPECT_TRUE(gathers_instead(patch, rays, kTarget));
  EXPECT_FALSE(gathers_instead(wall, rays, kTarget));
}

TEST(LightBudget, NoMoreRaysWhenGatheringIsCheaper) {
  // A hundred texels: the rays they would need cost more than gathering all their light.
  const TracedTexel x = texel(0.02, 2e3, 0.5);
  const std::vector<TracedTexel> texels(100, x);
  EXPECT_EQ(best_light_rays(texels, kTarget, 1000, kCostPerRay, kCosts), 1000);
}

TEST(LightBudget, TooFewDepositsGather) {
  TracedTexel x = texel(0.02, 1.0, 0.5);
  x.min_rays = 1e6;  // its neighbourhood reaches kMinDeposits at a million rays
  EXPECT_TRUE(gathers_instead(x, 1e5, kTarget));
  EXPECT_FALSE(gathers_instead(x, 1e6, kTarget));
}

}  // namespace
}  // namespace kiln::lightmap
