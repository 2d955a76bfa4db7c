// Light probe volumes through the lightmap bake (probe_volume.h, probe_outputs.h): placement near geometry, probes
// inside geometry invalid, the file's grids and metadata read back without kiln's own structures, bad settings
// refused by field, and a probe above a lightmapped floor against the floor's texels.
//
// Tolerances. Means over probes (or texels) that are independent estimates of one value are compared within 4.5
// standard errors of the mean from their spread (Student's t with 63 degrees of freedom exceeds 4.5 with probability
// 3·10⁻⁵), plus a stated bias bound where a term is not noise (SH truncation, a finite floor, float storage).
#include "bakers/lightmap/probe_outputs.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <limits>

#include "bakers/lightmap/lightmap_bake.h"
#include "bakers/math/constants.h"
#include "bakers/volume/probe_vdb.h"
#include "tests/support/test_scenes.h"

namespace kiln::lightmap {
namespace {

constexpr double kSigmas = 4.5;

LightmapBakeInput probes_input(scene::Scene s, const ProbeVolumeOptions& probes, uint64_t samples) {
  LightmapBakeInput in = test::lightmap_input(std::move(s), 8, 1e-4);
  in.lightmaps = false;
  in.probes = probes;
  in.min_samples = in.max_samples = samples;
  in.seed = 3;
  return in;
}

volume::ProbeVdbContents probes_file(const LightmapBakeResult& r) {
  const std::string& bytes = test::find_output(r, "probes.vdb").bytes;
  return volume::read_probe_vdb({reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()});
}

const volume::ProbeGridValues& grid(const volume::ProbeVdbContents& c, const std::string& name) {
  for (const auto& g : c.grids)
    if (g.name == name) return g;
  throw std::runtime_error("no grid " + name);
}

ProbeSh sh_of(const volume::ProbeVdbContents& c, size_t p) {
  ProbeSh sh;
  const char* ch[3] = {"r", "g", "b"};
  for (int k = 0; k < 9; ++k)
    for (int i = 0; i < 3; ++i) {
      const float v = grid(c, "sh" + std::to_string(k) + "_" + ch[i]).values[p];
      (i == 0 ? sh[k].r : i == 1 ? sh[k].g : sh[k].b) = v;
    }
  return sh;
}

nlohmann::json report(const LightmapBakeResult& r) {
  return nlohmann::json::parse(test::find_output(r, "report.json").bytes);
}

struct Mean {
  double mean = 0, se = 0;
};
Mean mean_of(const std::vector<double>& v) {
  double s = 0, s2 = 0;
  for (double x : v) s += x, s2 += x * x;
  const double n = static_cast<double>(v.size()), m = s / n;
  return {m, std::sqrt(std::max(0.0, (s2 - n * m * m) / (n - 1)) / n)};
}

// An open sky of radiance (0.5, 1, 2) and a black 1 cm tile 1 m below the region (the placement needs geometry; the
// tile hides at most 10⁻⁴ sr of 4π from any probe, 10⁻⁵ of the DC term, far below the noise).
TEST(ProbeVolume, UniformSkyGivesTheAnalyticShAndTheFileSaysHowToReadIt) {
  scene::Scene s;
  s.materials.push_back(test::lambert_material("black", 0.0));
  test::add_quad(s, "tile", {0, -1, 0}, {0.01, -1, 0}, {0.01, -1, -0.01}, {0, -1, -0.01}, 0, 1);
  const Rgb sky{0.5, 1.0, 2.0};
  s.environment.constant = sky;
  ProbeVolumeOptions o;
  o.regions = {{{-1, 0, -1}, {1, 1, 1}}};
  o.spacing = 0.5;
  o.max_distance = 10;
  const LightmapBakeResult r = bake_lightmaps(probes_input(s, o, 256));
  const volume::ProbeVdbContents c = probes_file(r);
  ASSERT_EQ(c.lattice.voxels.size(), 32u);  // 4 × 2 × 4 cell centres
  EXPECT_DOUBLE_EQ(c.lattice.voxel_size, 0.5);
  EXPECT_NEAR(c.lattice.origin.x, -0.75, 1e-12);
  EXPECT_NEAR(c.lattice.origin.y, 0.25, 1e-12);
  for (int k = 0; k < 9; ++k) {
    for (int ch = 0; ch < 3; ++ch) {
      std::vector<double> v;
      for (size_t p = 0; p < c.lattice.voxels.size(); ++p) v.push_back(sh_of(c, p)[k][ch]);
      const Mean m = mean_of(v);
      const double exact = k == 0 ? sky[ch] * std::sqrt(4 * kPi) : 0.0;
      // Plus float storage (10⁻⁶ relative) and 10⁻⁹ for exact zeros.
      EXPECT_NEAR(m.mean, exact, kSigmas * m.se + 1e-6 * std::abs(exact) + 1e-9) << "sh" << k << " channel " << ch;
    }
  }
  for (float v : grid(c, "validity").values) EXPECT_EQ(v, 1.0f);
  EXPECT_NE(c.metadata.at("kiln:sh_basis").find("0.282095"), std::string::npos);
  EXPECT_EQ(c.metadata.at("kiln:spacing"), "0.5");
  EXPECT_EQ(grid(c, "sh4_g").metadata.at("kiln:sh_index"), "4");
  EXPECT_EQ(grid(c, "sh4_g").metadata.at("kiln:channel"), "g");
  const nlohmann::json j = report(r);
  EXPECT_EQ(j["probes"]["counts"]["placed"], 32);
  EXPECT_EQ(j["probes"]["counts"]["valid"], 32);
  EXPECT_EQ(j["probes"]["samples_per_probe"]["max"], 256);
  EXPECT_NO_THROW(test::find_output(r, "probes_preview.png"));
}

// A closed box (outward faces: from inside, back faces only) in a lit sky: the probes inside are invalid with SH 0,
// those outside valid; the lattice points farther than max_distance from the box are skipped, not stored.
TEST(ProbeVolume, ProbesInsideAClosedBoxAreInvalidAndFarOnesAreNotStored) {
  scene::Scene s;
  s.materials.push_back(test::lambert_material("grey", 0.5));
  test::add_box(s, "box", {-0.5, -0.5, -0.5}, {0.5, 0.5, 0.5}, 0);
  s.environment.constant = Rgb{1.0};
  ProbeVolumeOptions o;
  o.regions = {{{-3, -0.25, -0.25}, {3, 0.25, 0.25}}};  // one row of probes along x at y = z = 0
  o.spacing = 0.5;
  o.max_distance = 1.0;
  const LightmapBakeResult r = bake_lightmaps(probes_input(s, o, 64));
  const volume::ProbeVdbContents c = probes_file(r);
  size_t inside = 0, outside = 0;
  for (size_t p = 0; p < c.lattice.voxels.size(); ++p) {
    const double x = c.lattice.origin.x + c.lattice.voxel_size * c.lattice.voxels[p][0];
    EXPECT_LE(std::abs(x), 1.5 + 1e-9) << "stored beyond max_distance of the box";
    const bool in = std::abs(x) < 0.5;
    EXPECT_EQ(grid(c, "validity").values[p], in ? 0.0f : 1.0f) << "x = " << x;
    if (in) {
      EXPECT_EQ(grid(c, "sh0_r").values[p], 0.0f);
    }
    (in ? inside : outside) += 1;
  }
  EXPECT_EQ(inside, 2u);   // x = ±0.25
  EXPECT_EQ(outside, 4u);  // x = ±0.75, ±1.25
  const nlohmann::json counts = report(r)["probes"]["counts"];
  EXPECT_EQ(counts["lattice_points"], 12);
  EXPECT_EQ(counts["placed"], 6);
  EXPECT_EQ(counts["invalid_inside_geometry"], 2);
  EXPECT_EQ(counts["skipped_far_from_geometry"], 6);
}

// A probe 0.25 m above a lightmapped floor (200 m wide, albedo 0.5) under a sky of 1 and a delta sun of 3 W/m² from
// cos θ = 0.8. The floor's texels hold E = π·1 + 3·0.8. The probe's order-2 reconstruction for the floor's normal
// (E(n) = Σ_l Â_l (2l+1)/4π Σ over the zonal expansion about n):
// - the sky above and the floor below (uniform radiance, as good as infinite) are a step across the horizon, whose
//   zonal coefficients vanish for even l ≥ 2, while the clamped cosine's vanish for odd l ≥ 3: the reconstruction is
//   exact for it (this is what tests the basis, its normalisation and its axes: a wrong axis loses the step's l = 1);
// - the sun, a delta, is reconstructed as E_sun·K2(cos θ), K2(x) = 1/4 + x/2 + (5/32)(3x² − 1) = 0.79375 at 0.8:
//   0.00625·E_sun too little, an exact and known truncation, added back before comparing;
// - the floor ends 98 m away: the horizon ring it leaves to the sky is < 2π·0.25/98 = 0.016 sr, seen through
//   |K2| ≤ 0.094 near the horizon: at most 0.0015 W/m² (radiances ≤ 1), added to the tolerance.
TEST(ProbeVolume, ProbeAboveALightmappedFloorAgreesWithItsTexels) {
  scene::Scene s;
  s.materials.push_back(test::lambert_material("floor", 0.5));
  test::add_floor(s, 200.0, 0);
  s.environment.constant = Rgb{1.0};
  scene::Light sun;
  sun.type = scene::LightShape::directional;
  sun.direction = normalize(Vec3{-0.6, -0.8, 0});
  sun.color = Rgb{3.0};
  s.lights.push_back(sun);
  LightmapBakeInput in = test::lightmap_input(s, 8, 1e-4);
  in.min_samples = in.max_samples = 256;
  in.probes.regions = {{{-2, 0, -2}, {2, 0.5, 2}}};  // 8 × 8 probes at y = 0.25
  in.probes.spacing = 0.5;
  const LightmapBakeResult r = bake_lightmaps(in);

  const image::FloatImage E = test::exr_output(r, "floor_irradiance.exr");
  std::vector<double> texels;
  for (size_t t = 0; t < E.pixels.size() / 3; ++t)
    texels.push_back(luminance(Rgb(E.pixels[3 * t], E.pixels[3 * t + 1], E.pixels[3 * t + 2])));
  const volume::ProbeVdbContents c = probes_file(r);
  ASSERT_EQ(c.lattice.voxels.size(), 64u);
  const double K2 = 0.25 + 0.8 / 2 + 5.0 / 32 * (3 * 0.64 - 1), truncation = 3.0 * (K2 - 0.8);
  std::vector<double> probes;
  for (size_t p = 0; p < c.lattice.voxels.size(); ++p) {
    probes.push_back(luminance(probe_irradiance(sh_of(c, p), {0, 1, 0})) - truncation);
  }
  const Mean floor = mean_of(texels), probe = mean_of(probes);
  const double exact = kPi + 3 * 0.8;
  std::printf("floor texels %.5f +- %.5f, probes (truncation %.4f removed) %.5f +- %.5f, exact %.5f\n", floor.mean,
              floor.se, truncation, probe.mean, probe.se, exact);
  EXPECT_NEAR(probe.mean, floor.mean, kSigmas * std::hypot(probe.se, floor.se) + 0.0015);
  EXPECT_NEAR(probe.mean, exact, kSigmas * probe.se + 0.0015);
  EXPECT_NEAR(floor.mean, exact, kSigmas * floor.se + 1e-5 * exact);
}

// Per-probe stopping: under a point light over a floor (bright probes near the light, dim ones far off), every valid
// probe ends at or below the target error, read from the file's error grid, with more estimates where it is noisier.
TEST(ProbeVolume, EveryProbeStopsAtTheTargetError) {
  ProbeVolumeOptions o;
  o.spacing = 0.5;
  o.max_distance = 1.0;
  LightmapBakeInput in = probes_input(test::floor_under_point_light(0.5, {0.4, 0.6, -0.3}, Rgb{2.0}), o, 0);
  in.target_error = 0.03;
  in.min_samples = 16;
  in.max_samples = 1 << 16;  // far above what the target takes: no probe stops for want of estimates
  const LightmapBakeResult r = bake_lightmaps(in);
  const volume::ProbeVdbContents c = probes_file(r);
  ASSERT_GT(c.lattice.voxels.size(), 0u);
  for (size_t p = 0; p < c.lattice.voxels.size(); ++p) {
    if (grid(c, "validity").values[p] == 1.0f) {
      EXPECT_LE(grid(c, "error").values[p], 0.03f) << "probe " << p;
    }
  }
  const nlohmann::json j = report(r)["probes"];
  EXPECT_EQ(j["error"]["above_target"], 0);
  EXPECT_LE(j["error"]["max"].get<double>(), 0.03);
  EXPECT_LT(j["samples_per_probe"]["min"].get<uint64_t>(), j["samples_per_probe"]["max"].get<uint64_t>());
  EXPECT_NE(j["decisions"].dump().find("every valid probe reached the target error"), std::string::npos);
}

// Regions that hold no geometry within max_distance: no probe, and still a file, a preview and a report that say so.
TEST(ProbeVolume, RegionsFarFromGeometryPlaceNoProbe) {
  ProbeVolumeOptions o;
  o.spacing = 0.5;
  o.regions = {{{50, 50, 50}, {52, 52, 52}}};
  const LightmapBakeResult r =
      bake_lightmaps(probes_input(test::floor_under_point_light(0.5, {0, 1, 0}, Rgb{1.0}), o, 16));
  EXPECT_TRUE(probes_file(r).lattice.voxels.empty());
  EXPECT_NO_THROW(test::find_output(r, "probes_preview.png"));
  const nlohmann::json counts = report(r)["probes"]["counts"];
  EXPECT_EQ(counts["placed"], 0);
  EXPECT_EQ(counts["lattice_points"], 64);
  EXPECT_EQ(counts["skipped_far_from_geometry"], 64);
  EXPECT_EQ(r.error_estimate, -1.0);  // no probe, no error: unknown, not 0
  EXPECT_NE(report(r)["probes"]["decisions"].dump().find("no probe was placed"), std::string::npos);
}

TEST(ProbeVolume, BadSettingsAreRefusedByField) {
  ProbeVolumeOptions o;
  o.spacing = 0;
  EXPECT_EQ(validate(o)->field(), "probes.spacing");
  o.spacing = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(validate(o)->field(), "probes.spacing");
  o.spacing = 1;
  o.max_distance = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(validate(o)->field(), "probes.max_distance");
  o.max_distance = -1;
  o.regions = {{{0, 0, 0}, {1, 0, 1}}};  // flat in y: no volume
  EXPECT_EQ(validate(o)->field(), "probes.regions[0].hi");
  o.regions = {{{0, std::numeric_limits<double>::quiet_NaN(), 0}, {1, 1, 1}}};
  EXPECT_EQ(validate(o)->field(), "probes.regions[0].lo.y");
  o.regions.clear();
  o.max_probes = 0;
  EXPECT_EQ(validate(o)->field(), "probes.max_probes");
  // A probes-only bake without probes.
  LightmapBakeInput in = test::lightmap_input(test::floor_under_point_light(0.5, {0, 1, 0}, Rgb{1.0}), 8, 0.1);
  in.lightmaps = false;
  EXPECT_EQ(validate(in)->field(), "probes.spacing");
}

// NaN in the scene (a vertex, a light) is dropped by the scene check: every stored value stays finite. Too many probes
// for max_probes double the spacing, and the report says why.
TEST(ProbeVolume, NanInputsGiveFiniteProbesAndTooManyProbesWidenTheSpacing) {
  scene::Scene s = test::floor_under_point_light(0.5, {0, 1, 0}, Rgb{1.0});
  s.meshes[0].positions[0].x = std::numeric_limits<double>::quiet_NaN();
  scene::Light bad = s.lights[0];
  bad.color = Rgb{std::numeric_limits<double>::quiet_NaN()};
  s.lights.push_back(bad);
  ProbeVolumeOptions o;
  o.spacing = 0.1;
  o.max_distance = 0.3;
  o.max_probes = 200;
  const LightmapBakeResult r = bake_lightmaps(probes_input(s, o, 32));
  const volume::ProbeVdbContents c = probes_file(r);
  EXPECT_LE(c.lattice.voxels.size(), 200u);
  EXPECT_GT(c.lattice.voxels.size(), 0u);
  for (const auto& g : c.grids)
    for (float v : g.values) EXPECT_TRUE(std::isfinite(v)) << g.name;
  const nlohmann::json p = report(r)["probes"];
  EXPECT_GT(p["spacing"].get<double>(), 0.1);
  EXPECT_NE(p["decisions"].dump().find("spacing doubled to 0.2"), std::string::npos) << p["decisions"];
}

TEST(ProbeVolume, PointTriangleDistanceMatchesEachRegion) {
  const Vec3 a{0, 0, 0}, b{1, 0, 0}, c{0, 1, 0};
  EXPECT_DOUBLE_EQ(point_triangle_distance({0.2, 0.2, 0.5}, a, b, c), 0.5);         // face
  EXPECT_DOUBLE_EQ(point_triangle_distance({-3, -4, 0}, a, b, c), 5.0);             // vertex a
  EXPECT_DOUBLE_EQ(point_triangle_distance({0.5, -2, 0}, a, b, c), 2.0);            // edge ab
  EXPECT_NEAR(point_triangle_distance({1, 1, 0}, a, b, c), std::sqrt(0.5), 1e-15);  // edge bc
  EXPECT_DOUBLE_EQ(point_triangle_distance({0, 0, 2}, a, a, a), 2.0);               // degenerate
}

}  // namespace
}  // namespace kiln::lightmap
