// Transmittance by delta and ratio tracking against closed forms and quadrature, and against each other.
//
// Tolerance: each Monte Carlo mean must lie within 4.5 standard errors (its own sample estimate) of the reference,
// per channel. For a normal estimate that fails with probability 7e-6 per comparison, so the ~150 comparisons here
// fail by chance with probability ~1e-3; the seeds are fixed, so a pass is reproducible.
#include "bakers/volume/tracking.h"

#include <gtest/gtest.h>

#include <cmath>

#include "bakers/volume/grid_medium.h"
#include "bakers/volume/homogeneous_medium.h"
#include "tests/volume/media_test_util.h"

namespace kiln::volume {
namespace {

using test::estimate;
using test::RgbEstimate;

constexpr double kSigmas = 4.5;

void expect_within(const RgbEstimate& e, const Rgb& reference, const char* what) {
  for (int c = 0; c < 3; ++c)
    EXPECT_LE(std::fabs(e.mean[c] - reference[c]), kSigmas * e.standard_error[c] + 1e-12)
        << what << " channel " << c << ": mean " << e.mean[c] << " ± " << e.standard_error[c] << ", reference "
        << reference[c];
}

Rgb exp_minus(const Rgb& tau) { return {std::exp(-tau.r), std::exp(-tau.g), std::exp(-tau.b)}; }

// A slab of fog 0 ≤ z ≤ d crossed at an angle: exp(−sigma_t·d/cos θ) per channel, each channel different.
TEST(Tracking, HomogeneousSlabTransmittanceIsExpMinusSigmaTTimesDistance) {
  const Rgb sigma_a{0.2, 0.5, 1.5}, sigma_s{0.3, 0.5, 0.5};  // sigma_t = (0.5, 1, 2)
  const double d = 1.0;
  const HomogeneousMedium slab({sigma_a, sigma_s, {}, 0.0, Bounds3{{-100, -100, 0}, {100, 100, d}}});
  for (double cos_theta : {1.0, 0.6, 0.25}) {
    const Vec3 dir{std::sqrt(1 - cos_theta * cos_theta), 0, cos_theta};
    const scene::Ray ray{{0, 0, -1}, dir * 2.0};  // non-unit direction: t in units of |direction|
    const double t_end = (d + 2) / (2.0 * cos_theta);
    const Rgb exact = exp_minus((sigma_a + sigma_s) * (d / cos_theta));
    Pcg32 rng(7, 1);
    expect_within(estimate(40000, [&] { return ratio_tracking_transmittance(slab, ray, t_end, rng); }), exact, "ratio");
    expect_within(estimate(40000, [&] { return delta_tracking_transmittance(slab, ray, t_end, rng); }), exact, "delta");
  }
}

TEST(Tracking, RayEndingInsideTheSlabSeesOnlyItsPart) {
  const HomogeneousMedium slab({{1, 1, 1}, {0, 0, 0}, {}, 0.0, Bounds3{{-1, -1, 0}, {1, 1, 1}}});
  const scene::Ray ray{{0, 0, -1}, {0, 0, 1}};
  Pcg32 rng(3);
  expect_within(estimate(20000, [&] { return ratio_tracking_transmittance(slab, ray, 1.25, rng); }),
                exp_minus(Rgb(0.25)), "ratio, partial");
}

// The same seed gives the same estimate, bit for bit.
TEST(Tracking, DeterministicGivenTheGenerator) {
  const GridMedium ball({test::lumpy_ball_grid(), {}, {}, {1, 2, 3}, {2, 1, 1}, {}, 0.3});
  const scene::Ray ray{{-0.5, 0.45, 0.5}, {1, 0.1, 0}};
  Pcg32 a(11, 5), b(11, 5);
  for (int i = 0; i < 100; ++i) {
    EXPECT_EQ(ratio_tracking_transmittance(ball, ray, 2, a), ratio_tracking_transmittance(ball, ray, 2, b));
    const FreeFlight fa = sample_free_flight(ball, ray, 2, a), fb = sample_free_flight(ball, ray, 2, b);
    EXPECT_EQ(fa.t, fb.t);
    EXPECT_EQ(fa.weight, fb.weight);
  }
}

// On a heterogeneous VDB grid (with empty leaves the majorant skips), delta and ratio tracking agree with each other
// and with quadrature of exp(−∫ sigma_t) (2·10⁵ midpoint steps: error ~1e-7, far below the Monte Carlo noise).
TEST(Tracking, DeltaAndRatioTrackingAgreeOnAHeterogeneousGrid) {
  const GridMedium ball({test::lumpy_ball_grid(), {}, {}, {0.5, 1, 2}, {1, 1, 1}, {}, 0.0});
  const scene::Ray rays[] = {{{-0.5, 0.45, 0.5}, {1, 0.1, 0}},
                             {{0.5, 0.5, -0.5}, {0.05, -0.02, 1}},
                             {{-0.2, -0.3, -0.1}, {0.7, 0.8, 0.6}},
                             {{0.1, 0.9, 0.2}, {0.2, -0.6, 0.3}}};
  Pcg32 rng(21, 2);
  for (const scene::Ray& ray : rays) {
    const double t_end = 3;
    const Rgb reference = test::quadrature_transmittance(ball, ray, t_end, 200000);
    const RgbEstimate ratio = estimate(30000, [&] { return ratio_tracking_transmittance(ball, ray, t_end, rng); });
    const RgbEstimate delta = estimate(30000, [&] { return delta_tracking_transmittance(ball, ray, t_end, rng); });
    expect_within(ratio, reference, "ratio vs quadrature");
    expect_within(delta, reference, "delta vs quadrature");
    for (int c = 0; c < 3; ++c) {
      const double se = std::hypot(ratio.standard_error[c], delta.standard_error[c]);
      EXPECT_LE(std::fabs(ratio.mean[c] - delta.mean[c]), kSigmas * se + 1e-12) << "channel " << c;
    }
  }
}

// A grid of constant density 1 is the homogeneous medium inside the voxel centres' box (trilinear interpolation of
// equal values): equal coefficients at every point (to float rounding of the interpolation weights, 1e-6 relative),
// equal majorants, and equal transmittances within the noise.
TEST(Tracking, ConstantDensityGridEqualsTheHomogeneousMedium) {
  const int n = 16;
  const VdbGrid ones = make_vdb_grid("density", n, n, n, std::vector<float>(n * n * n, 1.0f), 1.0 / n);
  const Rgb sigma_a{0.3, 0.6, 1.2}, sigma_s{0.7, 0.4, 0.3};
  const GridMedium grid({ones, {}, {}, sigma_a, sigma_s, {}, 0.0});
  const HomogeneousMedium fog({sigma_a, sigma_s, {}, 0.0, std::nullopt});
  Pcg32 rng(5);
  const double inner = (n - 1.0) / n;  // voxel centres span [0, 15/16]
  for (int i = 0; i < 200; ++i) {
    const Vec3 p{rng.uniform() * inner, rng.uniform() * inner, rng.uniform() * inner};
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(grid.at(p).sigma_a[c], sigma_a[c], 1e-6 * sigma_a[c]);
      EXPECT_NEAR(grid.at(p).sigma_s[c], sigma_s[c], 1e-6 * sigma_s[c]);
    }
  }
  const scene::Ray ray{{0.05, 0.1, 0.1}, {0.8, 0.7, 0.75}};  // stays inside [0, 15/16]³ for t ∈ [0, 1)
  const Rgb exact = exp_minus((sigma_a + sigma_s) * length(ray.direction));
  const RgbEstimate g = estimate(30000, [&] { return ratio_tracking_transmittance(grid, ray, 1, rng); });
  const RgbEstimate h = estimate(30000, [&] { return ratio_tracking_transmittance(fog, ray, 1, rng); });
  expect_within(g, exact, "grid");
  expect_within(h, exact, "homogeneous");
  const RgbEstimate gd = estimate(30000, [&] { return delta_tracking_transmittance(grid, ray, 1, rng); });
  expect_within(gd, exact, "grid, delta");
}

// Free flights through a scattering slab: the probability of scattering before escaping is 1 − T for a grey medium,
// and emission collected by the collision estimator equals the closed form ∫ T sigma_a Le dt = (sigma_a/sigma_t)
// Le (1 − T) along the ray.
TEST(Tracking, FreeFlightEventsAndEmissionMatchClosedForms) {
  const Rgb sigma_a{0.5, 0.5, 0.5}, sigma_s{1, 1, 1}, Le{2, 3, 4};
  const HomogeneousMedium slab({sigma_a, sigma_s, Le, 0.0, Bounds3{{-9, -9, 0}, {9, 9, 1}}});
  const scene::Ray ray{{0, 0, -1}, {0, 0, 1}};
  Pcg32 rng(9);
  const double T = std::exp(-1.5);
  const RgbEstimate scattered = estimate(40000, [&] {
    const FreeFlight f = sample_free_flight(slab, ray, 3, rng);
    return Rgb(f.event == FlightEvent::scattered ? 1.0 : 0.0);
  });
  expect_within(scattered, Rgb(sigma_s.r / 1.5 * (1 - T)), "scattered");
  const RgbEstimate emitted = estimate(40000, [&] { return sample_free_flight(slab, ray, 3, rng).emitted; });
  expect_within(emitted, Le * (sigma_a.r / 1.5 * (1 - T)), "emitted");
}

}  // namespace
}  // namespace kiln::volume
