// Leak probes on the generated level (tests/bench/level_scene.h) packed into atlas pages as level_bench packs them:
// one tile of a page rasterized as the bake rasterizes it, the leak scope's mask applied, and fix_leaks run twice on
// the same points: every probe ray traced in full (LeakOptions::end_probes_early off, the baseline) and ended early
// (the default). Prints each run's CPU seconds, rays and verdicts, checks that the verdicts and positions agree, and
// the ratio.
//
//   leak_bench [--page=P] [--tile=N] [--x0=X --y0=Y] [--texel-density=D] [--page-size=N] [--repeat=R]
//
// Defaults: page 1 (the page whose props sink into the terrain most), the tile of 1024² at (0, 0), 10 texels/m, pages
// of 2048². CPU seconds are of the whole process (both cores).
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "bakers/lightmap/atlas_pack.h"
#include "bakers/lightmap/leak_scope.h"
#include "bakers/lightmap/leaks.h"
#include "bakers/lightmap/texels.h"
#include "bakers/lightmap/tracer_query.h"
#include "bakers/scene/tracer.h"
#include "tests/bench/packed_level.h"
#include "tests/bench/process_cpu.h"

namespace kiln::bench {
namespace {

struct Args {
  int page = 1, tile = 1024, x0 = 0, y0 = 0, page_size = 2048, repeat = 1;
  double texel_density = 10;
};

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string s = argv[i];
    const auto value = [&s](const char* name) -> const char* {
      const size_t n = std::strlen(name);
      return s.compare(0, n, name) == 0 ? s.c_str() + n : nullptr;
    };
    if (const char* v = value("--page="))
      a.page = std::atoi(v);
    else if (const char* v = value("--tile="))
      a.tile = std::atoi(v);
    else if (const char* v = value("--x0="))
      a.x0 = std::atoi(v);
    else if (const char* v = value("--y0="))
      a.y0 = std::atoi(v);
    else if (const char* v = value("--page-size="))
      a.page_size = std::atoi(v);
    else if (const char* v = value("--texel-density="))
      a.texel_density = std::atof(v);
    else if (const char* v = value("--repeat="))
      a.repeat = std::atoi(v);
    else {
      std::fprintf(stderr, "leak_bench: unknown argument '%s' (see the top of tests/bench/leak_bench.cpp)\n",
                   s.c_str());
      std::exit(2);
    }
  }
  return a;
}

struct Run {
  double cpu = 0;
  lightmap::LeakReport report;
  lightmap::LightmapTexels texels;
};

Run run(const lightmap::LightmapTexels& texels, const lightmap::TracerRayQuery& query,
        const std::vector<uint8_t>& probe, bool end_early, int repeat) {
  lightmap::LeakOptions options;
  options.end_probes_early = end_early;
  Run r;
  for (int k = 0; k < repeat; ++k) {
    r.texels = texels;
    const double c0 = process_cpu_seconds();
    r.report = lightmap::fix_leaks(r.texels, query, options, {}, &probe);
    r.cpu += process_cpu_seconds() - c0;
  }
  r.cpu /= repeat;
  return r;
}

void print(const char* name, const Run& r, size_t probed) {
  std::printf("  %-22s %7.2f s CPU, %11llu rays (%.1f a point probed), %8zu moved, %8zu invalid, %.3g points/s CPU\n",
              name, r.cpu, static_cast<unsigned long long>(r.report.rays),
              static_cast<double>(r.report.rays) / static_cast<double>(probed), r.report.moved, r.report.invalidated,
              static_cast<double>(probed) / r.cpu);
}

}  // namespace
}  // namespace kiln::bench

int main(int argc, char** argv) {
  using namespace kiln;
  const bench::Args a = bench::parse(argc, argv);
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  lightmap::AtlasPack pack;
  const scene::CheckedScene checked = bench::packed_level(a.texel_density, a.page_size, pack);
  if (a.page < 0 || a.page >= static_cast<int>(pack.pages.size())) {
    std::fprintf(stderr, "leak_bench: --page=%d, but the level packs into %zu pages\n", a.page, pack.pages.size());
    return 2;
  }
  const scene::Tracer tracer(checked.scene);
  const lightmap::TracerRayQuery query(tracer, checked.scene, nullptr);
  const lightmap::LeakScope scope(checked.scene);
  std::vector<std::vector<uint8_t>> bake_mask;
  for (const auto& t : checked.triangles) bake_mask.push_back(t.bake);
  lightmap::RasterOptions raster;
  raster.width = raster.height = pack.pages[static_cast<size_t>(a.page)].size;
  raster.bake_mask = &bake_mask;
  raster.window = {a.x0, a.y0, a.tile, a.tile};
  lightmap::LightmapTexels texels =
      lightmap::rasterize_lightmap(checked.scene, lightmap::atlas_page_name(a.page), raster);
  lightmap::match_tracer_offsets(texels, tracer);
  const std::vector<uint8_t> probe = scope.probe_mask(texels.samples);
  size_t probed = 0;
  for (const uint8_t p : probe) probed += p;
  std::printf("level page %d (%d^2), tile %d^2 at (%d, %d): %zu valid texels, %zu sample points, %zu probed\n", a.page,
              raster.width, a.tile, a.x0, a.y0, texels.valid_count(), texels.samples.size(), probed);
  if (probed == 0) return 0;
  const bench::Run full = bench::run(texels, query, probe, false, a.repeat);
  bench::print("every ray in full", full, probed);
  const bench::Run early = bench::run(texels, query, probe, true, a.repeat);
  bench::print("ended early", early, probed);
  bool same = full.texels.samples.size() == early.texels.samples.size() && full.report.moved == early.report.moved;
  for (size_t j = 0; same && j < full.texels.samples.size(); ++j) {
    same = full.texels.samples[j].position == early.texels.samples[j].position;
  }
  std::printf("  same verdicts and positions: %s; ended early / in full: %.3f of the CPU time, %.3f of the rays\n",
              same ? "yes" : "NO", early.cpu / full.cpu,
              static_cast<double>(early.report.rays) / static_cast<double>(full.report.rays));
  return same ? 0 : 1;
}
