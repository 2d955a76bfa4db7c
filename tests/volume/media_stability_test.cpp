// The hard cases of issue 20 sweep through the media: zero density, density spikes of 1e6, g → ±1, NaN voxels and a
// medium outside the scene. Every result must be finite (and transmittances in [0, 1] for ratio tracking, whose
// factors are ≤ 1 and whose roulette lifts only estimates below 0.05, to at most 0.2); the reports say what
// happened.
#include <gtest/gtest.h>

#include <cmath>

#include "bakers/bake/invalid_input.h"
#include "bakers/volume/grid_medium.h"
#include "bakers/volume/henyey_greenstein.h"
#include "bakers/volume/homogeneous_medium.h"
#include "bakers/volume/medium_overlap.h"
#include "bakers/volume/tracking.h"
#include "tests/volume/media_test_util.h"

namespace kiln::volume {
namespace {

// Ratio and delta tracking and free flights along a fan of rays through [0, 1]³: all finite.
void expect_finite_tracking(const Medium& medium, int rays) {
  Pcg32 rng(99);
  for (int r = 0; r < rays; ++r) {
    const scene::Ray ray{{rng.uniform(), rng.uniform(), -0.5}, {rng.uniform() - 0.5, rng.uniform() - 0.5, 1}};
    const Rgb ratio = ratio_tracking_transmittance(medium, ray, 2, rng);
    ASSERT_TRUE(ratio.is_finite() && ratio.min() >= 0 && ratio.max() <= 1) << "ray " << r;
    ASSERT_TRUE(delta_tracking_transmittance(medium, ray, 2, rng).is_finite()) << "ray " << r;
    const FreeFlight f = sample_free_flight(medium, ray, 2, rng);
    ASSERT_TRUE(f.weight.is_finite() && f.emitted.is_finite() && std::isfinite(f.t)) << "ray " << r;
  }
}

// An all-zero grid stores nothing: transmittance exactly 1, no collision, and the medium reports itself empty.
TEST(MediaStability, ZeroDensityIsTransparent) {
  const VdbGrid zero = make_vdb_grid("density", 8, 8, 8, std::vector<float>(512, 0.0f), 0.125);
  const GridMedium medium({zero, {}, {}, {1, 1, 1}, {1, 1, 1}, {}, 0.0});
  Pcg32 rng(1);
  const scene::Ray ray{{0.5, 0.5, -1}, {0, 0, 1}};
  EXPECT_EQ(ratio_tracking_transmittance(medium, ray, 3, rng), Rgb(1));
  EXPECT_EQ(delta_tracking_transmittance(medium, ray, 3, rng), Rgb(1));
  EXPECT_EQ(sample_free_flight(medium, ray, 3, rng).event, FlightEvent::escaped);
  const auto report = outside_scene(medium, Bounds3{{-1, -1, -1}, {1, 1, 1}});
  ASSERT_TRUE(report);
  EXPECT_NE(report->find("no density"), std::string::npos) << *report;
  // Zero coefficients on a dense grid: the majorant is 0 everywhere, transmittance exactly 1.
  const GridMedium clear({test::lumpy_ball_grid(), {}, {}, {0, 0, 0}, {0, 0, 0}, {}, 0.0});
  EXPECT_EQ(ratio_tracking_transmittance(clear, ray, 3, rng), Rgb(1));
  expect_finite_tracking(clear, 50);
}

// A voxel of 1e6 in a haze of 0.5 (voxel 1/32, sigma_t up to 3 per unit density): the cap (a voxel's optical depth
// 1000 in the densest channel: 1000 / (3 · 1/32) ≈ 10667) bounds the null collisions; rays through the spike are
// (nearly) opaque, rays away from it see the haze.
TEST(MediaStability, DensitySpikesStayFiniteAndBounded) {
  const int n = 32;
  std::vector<float> v(n * n * n, 0.5f);
  v[(16 * n + 16) * n + 16] = 1e6f;
  const GridMedium medium({make_vdb_grid("density", n, n, n, v, 1.0 / n), {}, {}, {1, 1, 2}, {1, 0.5, 1}, {}, 0.0});
  EXPECT_NEAR(medium.density_cap(), 1000.0 / (3.0 / n), 1e-9 * medium.density_cap());
  expect_finite_tracking(medium, 100);
  Pcg32 rng(2);
  const scene::Ray through{{0.5, 0.5, -1}, {0, 0, 1}};  // voxel 16's centre is at 0.5
  const auto t = test::estimate(200, [&] { return ratio_tracking_transmittance(medium, through, 3, rng); });
  EXPECT_LT(t.mean.max(), 1e-6);
  const scene::Ray away{{0.2, 0.2, -1}, {0, 0, 1}};
  const Rgb haze = test::quadrature_transmittance(medium, away, 3, 100000);
  const auto a = test::estimate(4000, [&] { return ratio_tracking_transmittance(medium, away, 3, rng); });
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(a.mean[c], haze[c], 4.5 * a.standard_error[c] + 1e-12);
}

// NaN and infinite voxels read as 0 (counted); the medium built on them tracks finitely.
TEST(MediaStability, NanVoxelsReadAsZero) {
  std::vector<float> v(16 * 16 * 16, 1.0f);
  for (size_t i = 0; i < v.size(); i += 5) v[i] = NAN;
  v[7] = INFINITY;
  const VdbGrid grid = make_vdb_grid("density", 16, 16, 16, v, 1.0 / 16);
  EXPECT_EQ(grid.replaced_non_finite(), static_cast<int64_t>((v.size() + 4) / 5 + 1));
  const GridMedium medium({grid, {}, {}, {1, 2, 3}, {1, 1, 1}, {}, 0.5});
  Pcg32 rng(3);
  for (int i = 0; i < 1000; ++i) {
    const Vec3 p{rng.uniform(), rng.uniform(), rng.uniform()};
    ASSERT_TRUE(medium.at(p).sigma_t().is_finite() && medium.at(p).sigma_t().min() >= 0);
  }
  expect_finite_tracking(medium, 200);
}

// g = ±1 is accepted by a medium (volume::limits::kMediumAsymmetry) and narrowed by the phase function; g outside, or
// NaN coefficients, are rejected naming the field.
TEST(MediaStability, AsymmetryLimitsAndBadCoefficients) {
  for (double g : {-1.0, 1.0}) {
    const HomogeneousMedium fog({{0.1, 0.1, 0.1}, {1, 1, 1}, {}, g, std::nullopt});
    const HenyeyGreenstein hg(fog.g());
    const auto s = hg.sample({0, 0, 1}, {0.3, 0.7});
    EXPECT_TRUE(is_finite(s.wi) && std::isfinite(s.pdf) && s.pdf > 0) << "g " << g;
    expect_finite_tracking(fog, 50);
  }
  auto field_of = [](const HomogeneousMediumSpec& spec) {
    try {
      HomogeneousMedium m(spec);
    } catch (const bake::InvalidInput& e) {
      return e.field();
    }
    return std::string("accepted");
  };
  EXPECT_EQ(field_of({{0, 0, 0}, {1, 1, 1}, {}, 1.5, std::nullopt}), "g");
  EXPECT_EQ(field_of({{0, NAN, 0}, {1, 1, 1}, {}, 0, std::nullopt}), "sigma_a");
  EXPECT_EQ(field_of({{0, 0, 0}, {1, 1, -1}, {}, 0, std::nullopt}), "sigma_s");
  EXPECT_EQ(field_of({{0, 0, 0}, {1, 1, 1}, {}, 0, Bounds3{{1, 0, 0}, {0, 1, 1}}}), "box");
}

// A VDB placed far from the scene, and a fog box beside it, are reported with both boxes; fog filling the scene
// overlaps any scene.
TEST(MediaStability, MediaOutsideTheSceneAreReported) {
  const Bounds3 scene_bounds{{-1, -1, -1}, {1, 1, 1}};
  scene::Transform far;
  far.m[3] = 100;  // translate x by 100
  const GridMedium ball({test::lumpy_ball_grid(), {}, far, {1, 1, 1}, {1, 1, 1}, {}, 0.0});
  const auto report = outside_scene(ball, scene_bounds);
  ASSERT_TRUE(report);
  EXPECT_NE(report->find("do not overlap the scene's [(-1, -1, -1), (1, 1, 1)]"), std::string::npos) << *report;
  const HomogeneousMedium beside({{1, 1, 1}, {0, 0, 0}, {}, 0.0, Bounds3{{2, 0, 0}, {3, 1, 1}}});
  EXPECT_TRUE(outside_scene(beside, scene_bounds));
  const HomogeneousMedium fog({{1, 1, 1}, {0, 0, 0}, {}, 0.0, std::nullopt});
  EXPECT_FALSE(outside_scene(fog, scene_bounds));
  const GridMedium near({test::lumpy_ball_grid(), {}, {}, {1, 1, 1}, {1, 1, 1}, {}, 0.0});
  EXPECT_FALSE(outside_scene(near, scene_bounds));
}

// Rays that do not move, or carry NaN or infinite coordinates, cross no medium: transmittance 1, no collision.
TEST(MediaStability, DegenerateRaysCrossNothing) {
  const GridMedium ball({test::lumpy_ball_grid(), {}, {}, {1, 1, 1}, {1, 1, 1}, {}, 0.0});
  const HomogeneousMedium fog({{1, 1, 1}, {1, 1, 1}, {}, 0.0, std::nullopt});
  const scene::Ray rays[] = {{{0.5, 0.5, 0.5}, {0, 0, 0}},
                             {{NAN, 0.5, 0.5}, {1, 0, 0}},
                             {{0.5, 0.5, 0.5}, {INFINITY, 0, 0}},
                             {{0.5, 0.5, 0.5}, {0, NAN, 1}}};
  Pcg32 rng(8);
  for (const Medium* m : {static_cast<const Medium*>(&ball), static_cast<const Medium*>(&fog)})
    for (const scene::Ray& ray : rays) {
      EXPECT_EQ(ratio_tracking_transmittance(*m, ray, 1, rng), Rgb(1));
      EXPECT_EQ(delta_tracking_transmittance(*m, ray, 1, rng), Rgb(1));
    }
}

// A singular placement is rejected naming to_world.
TEST(MediaStability, SingularTransformIsRejected) {
  scene::Transform flat;
  flat.m[10] = 0;  // z collapses
  try {
    GridMedium m({test::lumpy_ball_grid(), {}, flat, {1, 1, 1}, {1, 1, 1}, {}, 0.0});
    ADD_FAILURE() << "accepted a singular transform";
  } catch (const bake::InvalidInput& e) {
    EXPECT_EQ(e.field(), "to_world");
  }
}

}  // namespace
}  // namespace kiln::volume
