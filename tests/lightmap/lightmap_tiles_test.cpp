// A page baked a tile at a time (LightmapBakeInput::tile_size, memory_limit_bytes) against the same page baked
// whole: the same answer within the noise, the analytic scenes still exact, the same bytes for the same tiles on
// any number of threads, and a memory limit that the estimate would exceed untiled choosing tiles.
#include <gtest/gtest.h>

#include <tbb/task_arena.h>

#include <cmath>
#include <string>

#include <nlohmann/json.hpp>

#include "bakers/image/exr.h"
#include "bakers/lightmap/lightmap_bake.h"
#include "bakers/lightmap/memory_estimate.h"
#include "bakers/math/constants.h"
#include "tests/support/test_scenes.h"

namespace kiln::lightmap {
namespace {

using test::exr_output;

double luminance(const image::FloatImage& img, int x, int y) {
  return 0.2126 * img.at(x, y, 0) + 0.7152 * img.at(x, y, 1) + 0.0722 * img.at(x, y, 2);
}

nlohmann::json report_of(const LightmapBakeResult& r) {
  return nlohmann::json::parse(test::find_output(r, "report.json").bytes);
}

// A floor under a square light with a box on it (a shadow, light bouncing off the box) and a grey floor: direct and
// indirect light, AO and the denoiser, so that every per-texel result crosses the tiles.
LightmapBakeInput shadowed_floor(int resolution) {
  scene::Scene s = test::floor_under_square_light();
  s.materials[0] = test::lambert_material("floor", 0.5);
  test::add_box(s, "box", {-0.5, 0.0, -0.1}, {-0.1, 0.4, 0.3}, 0);
  LightmapBakeInput in = test::lightmap_input(s, resolution, 0.03);
  in.resolutions["box"] = 16;
  in.ao = true;
  in.denoise = true;
  in.max_samples = 256;
  in.force_effects["light_tracing"] = false;  // the tiled bake cannot trace light; compare like with like
  return in;
}

// Under the lightmap metric a texel's error is relative to its page's brightness (in the report), under the texel
// metric to its own luminance.
double standard_error(const LightmapBakeResult& r, const std::string& name, double error, double texel_luminance) {
  const nlohmann::json report = report_of(r);
  if (report["error_metric"] == "texel") return error * texel_luminance;
  for (const auto& m : report["lightmaps"]) {
    if (m["name"] == name) return error * m["brightness"].get<double>();
  }
  throw std::runtime_error("no lightmap " + name + " in the report");
}

// Per texel, tiled against whole: the luminances differ by at most kEstimatedSigmas of their combined standard
// errors. The two bakes draw the same sequences per texel (seeded by the texel's place in its page), so most texels
// agree far closer than that; texels at tile borders pool their neighbours' variances differently and may take
// other batch sizes, and under the lightmap metric a tile's target scales with the brightness of the page so far.
void compare_whole_and_tiled(LightmapBakeInput in) {
  const LightmapBakeResult whole = bake_lightmaps(in);
  in.tile_size = 16;
  const LightmapBakeResult tiled = bake_lightmaps(in);
  EXPECT_EQ(report_of(tiled)["memory"]["tile_size"], 16);
  EXPECT_EQ(report_of(tiled)["memory"]["tiles"], 16 + 1) << "16 tiles of the floor's page, 1 of the box's";
  EXPECT_EQ(report_of(whole)["memory"]["tiled"], false);
  EXPECT_EQ(report_of(tiled)["time_budget"]["on"], false) << "no time limit, nothing to budget";
  for (const char* name : {"floor", "box"}) {
    const std::string n = name;
    const image::FloatImage Ew = exr_output(whole, n + "_irradiance.exr"), Et = exr_output(tiled, n + "_irradiance.exr");
    const image::FloatImage ew = exr_output(whole, n + "_error.exr"), et = exr_output(tiled, n + "_error.exr");
    const image::FloatImage vw = exr_output(whole, n + "_validity.exr"), vt = exr_output(tiled, n + "_validity.exr");
    int compared = 0;
    double worst = 0;
    for (int y = 0; y < Ew.height; ++y) {
      for (int x = 0; x < Ew.width; ++x) {
        ASSERT_EQ(vw.at(x, y, 0), vt.at(x, y, 0)) << n << " texel " << x << "," << y << ": the same validity";
        if (vw.at(x, y, 0) != 1.0f) continue;
        const double yw = luminance(Ew, x, y), yt = luminance(Et, x, y);
        const double sigma =
            std::hypot(standard_error(whole, n, ew.at(x, y, 0), yw), standard_error(tiled, n, et.at(x, y, 0), yt));
        EXPECT_LE(std::fabs(yw - yt), test::kEstimatedSigmas * sigma + 1e-6 * yw) << n << " texel " << x << "," << y;
        if (sigma > 0) worst = std::max(worst, std::fabs(yw - yt) / sigma);
        ++compared;
      }
    }
    EXPECT_GT(compared, n == "box" ? 100 : 2000) << n;
    std::printf("[ tiles    ] %s, %s metric: %d texels, largest difference %.2f combined standard errors\n", name,
                to_string(in.error_metric), compared, worst);
    // AO is a mean of the same estimates; the denoised image a filter of the page's results.
    const image::FloatImage aw = exr_output(whole, n + "_ao.exr"), at = exr_output(tiled, n + "_ao.exr");
    const image::FloatImage dt = exr_output(tiled, n + "_irradiance_denoised.exr");
    for (int y = 0; y < Ew.height; ++y) {
      for (int x = 0; x < Ew.width; ++x) {
        if (vw.at(x, y, 0) != 1.0f) continue;
        EXPECT_NEAR(aw.at(x, y, 0), at.at(x, y, 0), 0.25) << n << " AO at " << x << "," << y;
        EXPECT_TRUE(std::isfinite(dt.at(x, y, 0)));
      }
    }
  }
}

TEST(LightmapTiles, ATiledPageEqualsTheWholePageWithinTheNoise) {
  for (const ErrorMetric metric : {ErrorMetric::texel, ErrorMetric::lightmap}) {
    LightmapBakeInput in = shadowed_floor(64);
    in.error_metric = metric;
    compare_whole_and_tiled(in);
  }
}

// The analytic scenes of lightmap_bake_test.cpp, tiled: the uniform sky's π to float storage, Lambert's polygon
// formula to kEstimatedSigmas of the texel's error and the 1e-3 quadrature tolerance stated there.
TEST(LightmapTiles, TheAnalyticScenesStayExactWhenTiled) {
  scene::Scene sky;
  sky.materials.push_back(test::lambert_material("grey", 0.5));
  test::add_floor(sky, 2.0, 0);
  sky.environment.constant = Rgb{1.0};
  LightmapBakeInput in = test::lightmap_input(sky, 32, 0.01);
  in.tile_size = 16;
  const image::FloatImage E = exr_output(bake_lightmaps(in), "floor_irradiance.exr");
  for (int y = 0; y < 32; ++y) {
    for (int x = 0; x < 32; ++x) EXPECT_NEAR(E.at(x, y, 1), kPi, 1e-6) << x << "," << y;
  }

  const scene::Scene lit = test::floor_under_square_light();
  LightmapBakeInput rect = test::lightmap_input(lit, 32, 0.01);
  rect.tile_size = 16;
  const LightmapBakeResult r = bake_lightmaps(rect);
  const image::FloatImage R = exr_output(r, "floor_irradiance.exr"), err = exr_output(r, "floor_error.exr");
  const std::vector<double> exact = test::texel_means(lit, "floor", 32, [&](const Vec3& p, const Vec3& n) {
    return test::rect_light_irradiance(lit.lights[0], p, n);
  });
  for (int y = 0; y < 32; ++y) {
    for (int x = 0; x < 32; ++x) {
      const double e = exact[static_cast<size_t>(y) * 32 + x];
      EXPECT_NEAR(R.at(x, y, 0), e, e * (test::kEstimatedSigmas * err.at(x, y, 0) + 1e-3) + 1e-9) << x << "," << y;
    }
  }
}

// The same tiles give the same bytes, on one thread or on all of them.
TEST(LightmapTiles, TheSameTilesGiveTheSameBytesOnAnyNumberOfThreads) {
  LightmapBakeInput in = shadowed_floor(32);
  in.tile_size = 16;
  const LightmapBakeResult all = bake_lightmaps(in);
  LightmapBakeResult one;
  tbb::task_arena arena(1);
  arena.execute([&] { one = bake_lightmaps(in); });
  ASSERT_EQ(all.outputs.size(), one.outputs.size());
  for (size_t i = 0; i < all.outputs.size(); ++i) {
    if (all.outputs[i].name == "report.json") continue;  // times
    EXPECT_EQ(all.outputs[i].bytes, one.outputs[i].bytes) << all.outputs[i].name;
  }
}

// A memory limit below the untiled estimate picks tiles whose estimate fits it, and the bake holds less than that
// in its texels; light tracing is off, and says why.
TEST(LightmapTiles, AMemoryLimitBelowTheWholeEstimatePicksTiles) {
  scene::Scene s = test::floor_under_square_light();
  s.materials[0] = test::lambert_material("floor", 0.5);
  LightmapBakeInput in = test::lightmap_input(s, 256, 0.1);
  in.error_metric = ErrorMetric::lightmap;  // the texel metric would keep light tracing off on its own
  in.max_samples = 16;
  in.min_samples = 8;
  const LightmapBakeResult whole = bake_lightmaps(in);
  const nlohmann::json w = report_of(whole)["memory"];
  const uint64_t whole_estimate = w["estimate_bytes"];
  in.memory_limit_bytes = whole_estimate / 4;
  const LightmapBakeResult tiled = bake_lightmaps(in);
  const nlohmann::json m = report_of(tiled)["memory"];
  EXPECT_EQ(m["tiled"], true);
  EXPECT_GE(m["tile_size"].get<int>(), kMinTileSize);
  EXPECT_LE(m["estimate_bytes"].get<uint64_t>(), in.memory_limit_bytes);
  EXPECT_LE(m["held_peak_bytes"].get<uint64_t>(), m["estimate_bytes"].get<uint64_t>());
  EXPECT_LT(m["held_peak_bytes"].get<uint64_t>(), w["held_peak_bytes"].get<uint64_t>() / 4);
  bool said = false;
  const nlohmann::json report = report_of(tiled);
  for (const auto& d : report["plan"]) {
    if (d["effect"] == "light_tracing") {
      EXPECT_EQ(d["enabled"], false);
      said = d["reason"].get<std::string>().find("tiled") != std::string::npos;
    }
  }
  EXPECT_TRUE(said) << "the plan says light tracing is off because the bake is tiled";
  std::printf("[ tiles    ] 256² floor: estimate %s whole, %s in tiles of %d under a limit of %s; held %s and %s\n",
              format_bytes(whole_estimate).c_str(), format_bytes(m["estimate_bytes"]).c_str(),
              m["tile_size"].get<int>(), format_bytes(in.memory_limit_bytes).c_str(),
              format_bytes(w["held_peak_bytes"]).c_str(), format_bytes(m["held_peak_bytes"]).c_str());
}

TEST(LightmapTiles, ForcingLightTracingOnATiledBakeIsRefused) {
  LightmapBakeInput in = test::lightmap_input(test::floor_under_square_light(), 32, 0.1);
  in.error_metric = ErrorMetric::lightmap;  // the texel metric is an obstacle of its own
  in.tile_size = 16;
  in.force_effects["light_tracing"] = true;
  try {
    bake_lightmaps(in);
    FAIL() << "light tracing cannot serve a tiled bake";
  } catch (const bake::InvalidInput& e) {
    EXPECT_EQ(e.field(), "force_effects");
    EXPECT_NE(e.problem().find("tiled"), std::string::npos) << e.problem();
  }
}

TEST(LightmapTiles, ATileSizeOutOfRangeIsRefusedByName) {
  LightmapBakeInput in = test::lightmap_input(test::floor_under_square_light(), 32, 0.1);
  in.tile_size = 8;
  ASSERT_TRUE(validate(in).has_value());
  EXPECT_EQ(validate(in)->field(), "tile_size");
}

}  // namespace
}  // namespace kiln::lightmap
