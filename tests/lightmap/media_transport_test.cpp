// Participating media in the lightmap transport against analytic answers (issue 20), through the whole bake: a floor
// under a sun through an absorbing slab gets E·cos θ·exp(−σa·d/cos θ); single scattering in a homogeneous slab lit
// by the sun equals its closed form (the radiance along each direction in closed form, its cosine-weighted integral
// over the hemisphere by quadrature); a white-furnace medium (albedo 1 everywhere, a constant sky) leaves the
// irradiance π·L; a VDB layer of constant density attenuates as a slab does. Coefficients differ per channel, so each
// channel checks the spectral tracking's weights.
//
// Tolerance: every reference is the same at every texel, so the texels are independent estimates of one value; the
// standard error of their mean is taken from their spread (sd/√N over N = 64 texels), and each channel's mean must be
// within 4.5 of it (Student's t with 63 degrees of freedom exceeds 4.5 with probability 3·10⁻⁵ per comparison), plus
// 10⁻⁵ relative for float storage and the quadrature. Seeds are fixed. The thin-haze comparison adds the bias its plan
// allows (below).
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "bakers/lightmap/lightmap_bake.h"
#include "bakers/math/constants.h"
#include "bakers/volume/henyey_greenstein.h"
#include "bakers/volume/vdb_file.h"
#include "tests/support/test_scenes.h"

namespace kiln::lightmap {
namespace {

constexpr int kW = 8;               // texels on a side: 64 independent estimates
constexpr double kSigmas = 4.5;     // see the top of the file
constexpr double kRelative = 1e-5;  // float storage, quadrature

// A 2 m floor at y = 0 of albedo rho under a delta sun of irradiance E_n travelling along `direction`.
scene::Scene floor_under_sun(double rho, const Vec3& direction, double E_n) {
  scene::Scene s;
  s.materials.push_back(test::lambert_material("floor", rho));
  test::add_floor(s, 2.0, 0);
  scene::Light sun;
  sun.type = scene::LightShape::directional;
  sun.direction = normalize(direction);
  sun.color = Rgb{E_n};
  s.lights.push_back(sun);
  return s;
}

// A slab of the given coefficients, y in [−1, top], 100 m wide: as good as infinite for a floor 2 m wide (a ray
// reaching its sides has crossed ≥ 49 m of it).
volume::MediumInput slab(double top, const Rgb& sigma_a, const Rgb& sigma_s, double g) {
  volume::HomogeneousMediumSpec spec;
  spec.sigma_a = sigma_a;
  spec.sigma_s = sigma_s;
  spec.g = g;
  spec.box = volume::Bounds3{{-50, -1, -50}, {50, top, 50}};
  volume::MediumInput m;
  m.name = "slab";
  m.spec = spec;
  return m;
}

LightmapBakeInput input(scene::Scene s, uint64_t samples) {
  LightmapBakeInput in = test::lightmap_input(std::move(s), kW, 1e-4);
  in.min_samples = in.max_samples = samples;
  in.seed = 7;
  return in;
}

// Per channel, the mean irradiance over the floor's texels and the standard error of that mean from their spread.
struct TexelMean {
  Rgb mean, standard_error;
};
TexelMean texel_mean(const LightmapBakeResult& r) {
  const image::FloatImage E = test::exr_output(r, "floor_irradiance.exr");
  const image::FloatImage valid = test::exr_output(r, "floor_validity.exr");
  double sum[3] = {}, sum2[3] = {};
  int n = 0;
  for (int y = 0; y < E.height; ++y) {
    for (int x = 0; x < E.width; ++x) {
      if (valid.at(x, y, 0) < 0.5) continue;
      ++n;
      for (int c = 0; c < 3; ++c) {
        sum[c] += E.at(x, y, c);
        sum2[c] += E.at(x, y, c) * E.at(x, y, c);
      }
    }
  }
  EXPECT_EQ(n, kW * kW);
  TexelMean m;
  double mean[3], se[3];
  for (int c = 0; c < 3; ++c) {
    mean[c] = sum[c] / n;
    se[c] = std::sqrt(std::max(0.0, (sum2[c] - n * mean[c] * mean[c]) / (n - 1)) / n);
  }
  m.mean = {mean[0], mean[1], mean[2]};
  m.standard_error = {se[0], se[1], se[2]};
  return m;
}

void expect_mean(const TexelMean& m, const Rgb& want, const char* what) {
  const double got[3] = {m.mean.r, m.mean.g, m.mean.b},
               se[3] = {m.standard_error.r, m.standard_error.g, m.standard_error.b};
  const double expected[3] = {want.r, want.g, want.b};
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(got[c], expected[c], kSigmas * se[c] + kRelative * expected[c])
        << what << " channel " << c << ": standard error " << se[c];
    std::printf("%s channel %d: %.6f (exact %.6f, standard error %.2g)\n", what, c, got[c], expected[c], se[c]);
  }
}

TEST(MediaTransport, AbsorbingSlabAttenuatesTheSunByBeersLaw) {
  const double theta = 0.6, depth = 0.8, E_n = 2.0;
  const Rgb sigma_a{0.2, 0.7, 1.5};
  LightmapBakeInput in = input(floor_under_sun(0.0, {std::sin(theta), -std::cos(theta), 0}, E_n), 64);
  in.media.push_back(slab(depth, sigma_a, Rgb{}, 0.0));
  const LightmapBakeResult r = bake_lightmaps(in);
  const double mu = std::cos(theta);
  auto E = [&](double a) { return E_n * mu * std::exp(-a * depth / mu); };
  expect_mean(texel_mean(r), Rgb{E(sigma_a.r), E(sigma_a.g), E(sigma_a.b)}, "absorbing slab");
}

// The irradiance at the floor of light scattered exactly once in the slab [0, H] (sun along d, μs = cos θs): along
// an upward direction ω (μ = ω·y), L(ω) = σs p(ω·(−d)) E_n ∫₀^{H/μ} e^{−σt (H − sμ)/μs} e^{−σt s} ds
// = σs p E_n e^{−σt H/μs} (1 − e^{−a H/μ})/a with a = σt (1 − μ/μs); E = ∫ L μ dω by the midpoint rule on (μ, φ).
double single_scattering(double sigma_a, double sigma_s, double g, double H, double theta_s, double E_n) {
  const double sigma_t = sigma_a + sigma_s, mu_s = std::cos(theta_s);
  const Vec3 to_sun{-std::sin(theta_s), std::cos(theta_s), 0};
  const volume::HenyeyGreenstein hg(g);
  constexpr int kMu = 2000, kPhi = 2000;
  double E = 0;
  for (int i = 0; i < kMu; ++i) {
    const double mu = (i + 0.5) / kMu, sin_t = std::sqrt(1 - mu * mu);
    const double a = sigma_t * (1 - mu / mu_s), x = a * H / mu;
    // (1 − e^{−x})/a = (H/μ)·(1 − e^{−x})/x, which tends to H/μ as a → 0.
    const double path = std::abs(x) < 1e-12 ? H / mu : -std::expm1(-x) / a;
    for (int j = 0; j < kPhi; ++j) {
      const double phi = 2 * kPi * (j + 0.5) / kPhi;
      const Vec3 w{sin_t * std::cos(phi), mu, sin_t * std::sin(phi)};
      E += sigma_s * hg.p(dot(w, to_sun)) * path * mu;
    }
  }
  return E * E_n * std::exp(-sigma_t * H / mu_s) * (1.0 / kMu) * (2 * kPi / kPhi);
}

TEST(MediaTransport, SingleScatteringMatchesItsClosedForm) {
  const double theta = 0.5, H = 1.0, E_n = 3.0, g = 0.4;
  const Rgb sigma_a{0.1, 0.2, 0.3}, sigma_s{0.3, 0.6, 1.2};
  LightmapBakeInput in = input(floor_under_sun(0.0, {std::sin(theta), -std::cos(theta), 0}, E_n), 256);
  in.media.push_back(slab(H, sigma_a, sigma_s, g));
  // One bounce: the sun's light scattered once (a black floor reflects nothing).
  in.max_bounces = 1;
  in.force_effects["indirect_bounces"] = true;
  const LightmapBakeResult r = bake_lightmaps(in);
  const double mu_s = std::cos(theta);
  auto E = [&](double a, double s) {
    return E_n * mu_s * std::exp(-(a + s) * H / mu_s) + single_scattering(a, s, g, H, theta, E_n);
  };
  expect_mean(texel_mean(r), Rgb{E(sigma_a.r, sigma_s.r), E(sigma_a.g, sigma_s.g), E(sigma_a.b, sigma_s.b)},
              "single scattering");
}

TEST(MediaTransport, WhiteFurnaceMediumLeavesTheSkyUnchanged) {
  // Nothing absorbs: a white floor (albedo 1) and a purely scattering box of fog around it under a constant sky of
  // radiance 1. The radiance is 1 everywhere, so every texel's irradiance is π, whatever the fog's density or phase.
  scene::Scene s;
  s.materials.push_back(test::lambert_material("white", 1.0));
  test::add_floor(s, 2.0, 0);
  s.environment.constant = Rgb{1.0};
  LightmapBakeInput in = input(std::move(s), 256);
  volume::HomogeneousMediumSpec fog;
  fog.sigma_s = Rgb{0.6, 1.0, 1.5};
  fog.g = 0.6;
  fog.box = volume::Bounds3{{-1.5, -0.5, -1.5}, {1.5, 1.5, 1.5}};
  in.media.push_back(volume::MediumInput{"fog", fog});
  const LightmapBakeResult r = bake_lightmaps(in);
  expect_mean(texel_mean(r), Rgb{kPi}, "white furnace");
}

const plan::Decision& decision(const LightmapBakeResult& r, const std::string& effect) {
  for (const plan::Decision& d : r.plan) {
    if (d.effect == effect) return d;
  }
  throw std::runtime_error("no decision for " + effect);
}

// A VDB density through the whole bake (the grid's majorants, its trilinear lookups, read_vdb's repairs): a layer of
// density 1 in voxels of 0.1 m, centres from y = 0.25 to 0.75, floating over the floor. Trilinear lookups ramp the
// density to 0 over one voxel beyond the outer centres, so the layer's optical depth along y is sigma_a × 0.6 exactly,
// and a floor texel under the sun gets E cos t exp(−sigma_a·0.6/cos t), as under a homogeneous slab 0.6 deep. The
// grid goes through write_vdb and read_vdb as a job's blob does.
TEST(MediaTransport, VdbLayerAttenuatesTheSunByBeersLaw) {
  constexpr int nx = 40, ny = 6, nz = 40;
  const std::vector<float> density(nx * ny * nz, 1.0f);
  const std::vector<uint8_t> file =
      volume::write_vdb({volume::make_vdb_grid("density", nx, ny, nz, density, 0.1, Vec3{-1.95, 0.25, -1.95})});
  const std::vector<volume::VdbGrid> grids = volume::read_vdb(file, {"density"});
  const double theta = 0.5, E_n = 2.0;
  const Rgb sigma_a{0.3, 0.8, 1.6};
  volume::GridMediumSpec layer;
  layer.density = grids[0];
  layer.sigma_a = sigma_a;
  LightmapBakeInput in = input(floor_under_sun(0.0, {std::sin(theta), -std::cos(theta), 0}, E_n), 64);
  in.media.push_back(volume::MediumInput{"layer", layer});
  const double mu = std::cos(theta);
  auto E = [&](double a) { return E_n * mu * std::exp(-a * 0.6 / mu); };
  const Rgb exact{E(sigma_a.r), E(sigma_a.g), E(sigma_a.b)};
  const LightmapBakeResult attenuated = bake_lightmaps(in);  // nothing scatters: attenuation only
  expect_mean(texel_mean(attenuated), exact, "VDB layer, attenuation only");
  in.force_effects["media_scattering"] = true;  // free flights by delta tracking through the same grid
  expect_mean(texel_mean(bake_lightmaps(in)), exact, "VDB layer, free flights");
  const auto& bytes = test::find_output(attenuated, "report.json").bytes;
  const nlohmann::json report = nlohmann::json::parse(bytes)["media"];
  EXPECT_EQ(report["media"][0]["kind"], "vdb");
  EXPECT_EQ(report["media"][0]["replaced_non_finite_voxels"], 0);
  EXPECT_EQ(report["mode"], "attenuation");
}

// The stability cases through the whole bake, each on its own: a grid with a density spike of 1e6 beside
// an empty half and scattering backwards (g = −1), and a fog scattering forwards (g = 1), over a grey floor lit by
// the sun and a sky: every texel finite, no estimate dropped. (The spike's leaf has a majorant ~10⁴ m⁻¹: rays through
// it take thousands of null collisions, bounded by the density cap, docs/MEDIA.md "Stability".)
TEST(MediaTransport, SpikesAndExtremeAsymmetryGiveFiniteLightmaps) {
  constexpr int n = 16;
  std::vector<float> density(n * n * n, 0.0f);
  for (int i = 0; i < n * n * n / 2; ++i) density[i] = 0.5f;  // the lower half; the upper half holds nothing
  density[n * n * 3 + n * 5 + 7] = 1e6f;
  volume::GridMediumSpec grid;
  grid.density = volume::make_vdb_grid("density", n, n, n, density, 0.1, Vec3{-0.8, 0.05, -0.8});
  grid.sigma_s = Rgb{1.0};
  grid.sigma_a = Rgb{0.1};
  grid.g = -1.0;
  volume::HomogeneousMediumSpec forward;
  forward.sigma_s = Rgb{0.2, 0.3, 0.4};
  forward.g = 1.0;
  forward.box = volume::Bounds3{{-1, 0, -1}, {1, 1, 1}};
  for (const volume::MediumInput& medium :
       {volume::MediumInput{"spiky", grid}, volume::MediumInput{"forward", forward}}) {
    scene::Scene s = floor_under_sun(0.5, {0.2, -1, 0.1}, 3.0);
    s.environment.constant = Rgb{0.5};
    LightmapBakeInput in = input(std::move(s), 8);
    in.media = {medium};
    const LightmapBakeResult r = bake_lightmaps(in);
    const image::FloatImage E = test::exr_output(r, "floor_irradiance.exr");
    for (float v : E.pixels) EXPECT_TRUE(std::isfinite(v)) << medium.name;
    EXPECT_TRUE(decision(r, "media_scattering").enabled) << medium.name;
    EXPECT_EQ(nlohmann::json::parse(test::find_output(r, "report.json").bytes)["dropped_samples"], 0) << medium.name;
  }
}

// A thin absorbing haze that scatters little: the planner simulates its attenuation only, which equals the full
// simulation within the noise and the bias the plan allows (target/4 of the value: what it leaves out is the light
// the haze scatters, at most albedo × what it takes), and costs less.
TEST(MediaTransport, ThinHazePlannedAsAttenuationOnlyEqualsTheFullSimulation) {
  const double target = 0.05, budget = target / 4;
  LightmapBakeInput in = input(floor_under_sun(0.0, {0.3, -1, 0.2}, 2.0), 128);
  in.target_error = target;
  in.media.push_back(slab(2.0, Rgb{0.05, 0.1, 0.15}, Rgb{0.001, 0.002, 0.003}, 0.2));
  const auto t0 = std::chrono::steady_clock::now();
  const LightmapBakeResult planned = bake_lightmaps(in);
  const auto t1 = std::chrono::steady_clock::now();
  in.full_simulation = true;
  const LightmapBakeResult full = bake_lightmaps(in);
  const auto t2 = std::chrono::steady_clock::now();
  EXPECT_TRUE(decision(planned, "participating_media").enabled);
  EXPECT_FALSE(decision(planned, "media_scattering").enabled) << decision(planned, "media_scattering").reason;
  EXPECT_NE(decision(planned, "media_scattering").reason.find("attenuation only"), std::string::npos);
  EXPECT_TRUE(decision(full, "media_scattering").enabled);
  const auto& bytes = test::find_output(planned, "report.json").bytes;
  const nlohmann::json report = nlohmann::json::parse(bytes);
  EXPECT_EQ(report["media"]["mode"], "attenuation");
  EXPECT_EQ(report["media"]["media"][0]["kind"], "box");
  EXPECT_EQ(report["media"]["media"][0]["simulated"], true);
  const TexelMean a = texel_mean(planned), b = texel_mean(full);
  for (int c = 0; c < 3; ++c) {
    const double se = std::hypot(a.standard_error[c], b.standard_error[c]);
    EXPECT_NEAR(a.mean[c], b.mean[c], kSigmas * se + budget * b.mean[c]) << "channel " << c;
    std::printf("thin haze channel %d: attenuation only %.6f +- %.2g, full %.6f +- %.2g\n", c, a.mean[c],
                a.standard_error[c], b.mean[c], b.standard_error[c]);
  }
  const double planned_s = std::chrono::duration<double>(t1 - t0).count();
  const double full_s = std::chrono::duration<double>(t2 - t1).count();
  std::printf("thin haze: planned %.3f s, %llu rays; full %.3f s, %llu rays\n", planned_s,
              static_cast<unsigned long long>(planned.rays), full_s, static_cast<unsigned long long>(full.rays));
  std::printf("plan: %s\n", decision(planned, "participating_media").reason.c_str());
}

}  // namespace
}  // namespace kiln::lightmap
