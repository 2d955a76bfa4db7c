// The lightmap bake's memory at scale: a generated level of P square planes (each 8 m, lit by a sun and a sky, a
// little apart so that none shadows another), each baked into its own S² lightmap page, under a memory limit, with
// each output written to disk as the bake hands it over (bake::BakeControl::output_sink, as kilnd does). It prints
// the peak resident set of the process (getrusage), the wall time, the bake's memory plan (whole pages or tiles, the
// estimate, the texel state and page results it held at most) and the bytes a texel holds while it is sampled.
//
//   lightmap_memory_bench [--pages=16] [--size=2048] [--limit=4G] [--time_limit=60] [--out=DIR] [--estimate_only]
//
// --estimate_only prints the estimates of the bake whole and under the limit (memory_estimate.h) without baking.
//
// The default is the target: 16 pages of 2048² (67 M texels) under 4 GiB. With a time limit the bake
// stops sampling when it runs out (the tiles after that are rasterized for their validity, not sampled) and still
// writes every page: the memory is the point, not the error. --limit=0 bakes whole pages (don't, at this size).
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "bakers/lightmap/lightmap_bake.h"
#include "bakers/lightmap/memory_estimate.h"
#include "tests/bench/byte_size_arg.h"
#include "tests/support/test_scenes.h"

namespace {

using namespace kiln;

double peak_rss_bytes() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) * 1024.0;  // kilobytes on Linux
}

scene::Scene level(int pages) {
  scene::Scene s;
  s.materials.push_back(test::lambert_material("ground", 0.5));
  for (int p = 0; p < pages; ++p) {
    const double x = (p % 4) * 10.0, z = (p / 4) * 10.0;
    test::add_quad(s, "plane" + std::to_string(p), {x, 0, z}, {x + 8, 0, z}, {x + 8, 0, z + 8}, {x, 0, z + 8}, 0, 2);
  }
  scene::Light sun;
  sun.type = scene::LightShape::directional;
  sun.direction = {-0.3, -1.0, -0.2};
  sun.color = Rgb{3.0};
  s.lights.push_back(sun);
  s.environment.constant = Rgb{0.3};
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  int pages = 16, size = 2048;
  uint64_t limit = uint64_t{4} << 30;
  double time_limit = 60;
  bool estimate_only = false;
  std::string out = (std::filesystem::temp_directory_path() / "kiln_lightmap_memory_bench").string();
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto value = [&](const char* flag) -> const char* {
      const size_t n = std::strlen(flag);
      return a.compare(0, n, flag) == 0 ? a.c_str() + n : nullptr;
    };
    if (const char* v = value("--pages=")) pages = std::atoi(v);
    else if (const char* v = value("--size=")) size = std::atoi(v);
    else if (const char* v = value("--limit=")) limit = kiln::bench::parse_bytes(v);
    else if (const char* v = value("--time_limit=")) time_limit = std::atof(v);
    else if (const char* v = value("--out=")) out = v;
    else if (a == "--estimate_only") estimate_only = true;
    else {
      std::fprintf(stderr, "unknown argument %s; see the top of lightmap_memory_bench.cpp\n", a.c_str());
      return 2;
    }
  }
  // The model's figures for this level: the whole bake and the plan under the limit.
  lightmap::LightmapJobSize job;
  job.lightmap_texels.assign(static_cast<size_t>(pages), static_cast<uint64_t>(size) * size);
  job.traced_triangles = static_cast<uint64_t>(pages) * 8;  // add_quad with n = 2
  job.streamed = true;
  const lightmap::LightmapMemoryEstimate whole = lightmap::estimate_memory(job, 0);
  const lightmap::LightmapMemoryEstimate planned = lightmap::plan_memory(job, limit);
  std::printf("estimate: whole pages %s (%.0f bytes a texel); under the limit %s, tiles of %d\n",
              lightmap::format_bytes(whole.total).c_str(), whole.bytes_per_texel,
              lightmap::format_bytes(planned.total).c_str(), planned.tile_size);
  if (estimate_only) return 0;
  std::filesystem::create_directories(out);
  lightmap::LightmapBakeInput in;
  in.scene = level(pages);
  in.resolution = size;
  in.target_error = 0.02;
  in.time_limit_seconds = time_limit;
  in.memory_limit_bytes = limit;
  const double rss_before = peak_rss_bytes();
  uint64_t written = 0;
  size_t files = 0;
  std::string report;
  bake::BakeControl control;
  control.output_sink = [&](bake::BakeOutput&& o) {
    std::ofstream(std::filesystem::path(out) / o.name, std::ios::binary)
        .write(o.bytes.data(), static_cast<std::streamsize>(o.bytes.size()));
    written += o.bytes.size();
    ++files;
    if (o.name == "report.json") report = std::move(o.bytes);
  };
  const auto t0 = std::chrono::steady_clock::now();
  const lightmap::LightmapBakeResult r = lightmap::bake_lightmaps(in, control);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double rss = peak_rss_bytes();
  const nlohmann::json j = nlohmann::json::parse(report);
  const auto& m = j["memory"];
  const double texels = static_cast<double>(pages) * size * size;
  std::printf("lightmap_memory_bench: %d pages of %d² (%.1f M texels), memory limit %s, time limit %g s\n", pages,
              size, texels / 1e6, lightmap::format_bytes(limit).c_str(), time_limit);
  std::printf("  peak RSS          %s (%s before the bake)\n",
              lightmap::format_bytes(static_cast<uint64_t>(rss)).c_str(),
              lightmap::format_bytes(static_cast<uint64_t>(rss_before)).c_str());
  std::printf("  wall time         %.1f s (samples %llu, rays %llu, error estimate %.4f)\n", seconds,
              static_cast<unsigned long long>(r.samples), static_cast<unsigned long long>(r.rays), r.error_estimate);
  std::printf("  plan              %s, tile %d, %llu tiles (%llu unsampled at the time limit)\n",
              m["tiled"].get<bool>() ? "tiled" : "whole pages", m["tile_size"].get<int>(),
              static_cast<unsigned long long>(m["tiles"].get<uint64_t>()),
              static_cast<unsigned long long>(m["tiles_unsampled"].get<uint64_t>()));
  std::printf("  estimate          %s; held at most %s in texel state and page results\n",
              lightmap::format_bytes(m["estimate_bytes"].get<uint64_t>()).c_str(),
              lightmap::format_bytes(m["held_peak_bytes"].get<uint64_t>()).c_str());
  std::printf("  bytes per texel   %.0f while sampled (sample points and state); %.1f per texel of the bake at peak "
              "RSS\n",
              m["bytes_per_texel_held"].get<double>(), rss / texels);
  std::printf("  outputs           %zu files, %s, in %s\n", files, lightmap::format_bytes(written).c_str(),
              out.c_str());
  return 0;
}
