// Large scenes: a generated game level (tests/bench/level_scene.h: a terrain and ~10,000 props of a few hundred
// meshes, ~1 M triangles in all, a sun and a sky) and a lone 1 M-triangle terrain.
//
//   level_bench [--quads=N] [--instances=N] [--meshes=N] [--detail=N] [--prop-resolution=N]
//               [--terrain-resolution=N] [--time-limit=S] [--skip-level] [--skip-terrain] [--skip-tracers]
//               [--texel-density=D [--page-size=N] [--max-pages=K] [--pack-only]] [--limit=BYTES]
//
// The level:
//   1. the tracer built three ways (scene::Instancing: every instance flattened; shared meshes instanced, the
//      default; every mesh instanced): build CPU and wall seconds, memory (Tracer::memory_bytes: Embree's memory
//      monitor and the tracer's arrays), triangles traced and held (--skip-tracers leaves 1 and 2 out, so that the
//      process's peak RSS is the bake's);
//   2. closest-hit rays per CPU-second through each (incoherent rays in the level's box, tests/bench/ray_workload.h,
//      one at a time on both cores);
//   3. a short bake (--time-limit): report.json's stages, samples, rays, texels, rates. Without --texel-density:
//      the terrain at --terrain-resolution, each prop mesh's atlas at --prop-resolution, every instance in a cell of
//      its mesh's atlas. With it: every instance packed into atlas pages at D texels per metre (--page-size, default
//      2048; --max-pages, default 64), and the packing's pages and efficiency. --limit (e.g. 4G) bounds the bake's
//      memory (tiles when the pages do not fit). --pack-only packs the pages and reports them without baking.
// The terrain: one 1 M-triangle height field (--quads 708: 2·708² triangles) at 1024² with the time limit: its
// stages and that samples are taken (no leak probe: it cannot leak, leak_scope.h).
//
// CPU seconds are of the whole process (all threads): the figures to trust on a shared machine; wall seconds move
// with what else runs.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <optional>
#include <string>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <nlohmann/json.hpp>

#include "bakers/lightmap/atlas_pack.h"
#include "bakers/lightmap/lightmap_bake.h"
#include "bakers/scene/scene_check.h"
#include "bakers/scene/tracer.h"
#include "tests/bench/byte_size_arg.h"
#include "tests/bench/level_scene.h"
#include "tests/bench/ray_workload.h"

namespace kiln::bench {
namespace {

double cpu_seconds() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}
double wall_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

struct Args {
  LevelOptions level;
  int prop_resolution = 32, terrain_resolution = 512, terrain_quads = 708;
  double time_limit = 30;
  double texel_density = 0;
  int page_size = 2048, max_pages = 64;
  uint64_t limit = 0;
  bool skip_level = false, skip_terrain = false, skip_tracers = false, pack_only = false;
};

Args parse(int argc, char** argv) {
  Args a;
  a.level.terrain_quads = 400;  // 320k triangles of terrain, the rest props
  a.level.prop_detail = 9;
  for (int i = 1; i < argc; ++i) {
    const std::string s = argv[i];
    const auto value = [&](const char* flag) -> std::optional<double> {
      const std::string f = std::string(flag) + "=";
      if (s.rfind(f, 0) != 0) return std::nullopt;
      return std::atof(s.c_str() + f.size());
    };
    if (auto v = value("--quads"))
      a.level.terrain_quads = static_cast<int>(*v);
    else if (auto v2 = value("--instances"))
      a.level.instances = static_cast<int>(*v2);
    else if (auto v3 = value("--meshes"))
      a.level.meshes = static_cast<int>(*v3);
    else if (auto v4 = value("--detail"))
      a.level.prop_detail = static_cast<int>(*v4);
    else if (auto v5 = value("--prop-resolution"))
      a.prop_resolution = static_cast<int>(*v5);
    else if (auto v6 = value("--terrain-resolution"))
      a.terrain_resolution = static_cast<int>(*v6);
    else if (auto v7 = value("--terrain-quads"))
      a.terrain_quads = static_cast<int>(*v7);
    else if (auto v8 = value("--time-limit"))
      a.time_limit = *v8;
    else if (auto v9 = value("--texel-density"))
      a.texel_density = *v9;
    else if (auto v10 = value("--page-size"))
      a.page_size = static_cast<int>(*v10);
    else if (auto v11 = value("--max-pages"))
      a.max_pages = static_cast<int>(*v11);
    else if (s.rfind("--limit=", 0) == 0)
      a.limit = parse_bytes(s.substr(8));
    else if (s == "--skip-level")
      a.skip_level = true;
    else if (s == "--skip-terrain")
      a.skip_terrain = true;
    else if (s == "--skip-tracers")
      a.skip_tracers = true;
    else if (s == "--pack-only")
      a.pack_only = true;
    else {
      std::fprintf(stderr, "level_bench: unknown argument '%s' (see the top of tests/bench/level_bench.cpp)\n",
                   s.c_str());
      std::exit(2);
    }
  }
  return a;
}

const char* name(scene::Instancing i) {
  return i == scene::Instancing::none     ? "flattened"
         : i == scene::Instancing::shared ? "shared instanced"
                                          : "all instanced";
}

void tracers(const scene::Scene& clean) {
  std::printf("\n%-17s %9s %9s %11s %11s %11s %12s %9s\n", "tracer", "build cpu", "wall s", "memory MB", "triangles",
              "held", "Mrays/cpu_s", "hit frac");
  std::vector<scene::Ray> rays;
  for (scene::Instancing inst : {scene::Instancing::none, scene::Instancing::shared, scene::Instancing::all}) {
    scene::TracerOptions o;
    o.instancing = inst;
    const double c0 = cpu_seconds(), w0 = wall_seconds();
    const scene::Tracer tracer(clean, o);
    const double build_cpu = cpu_seconds() - c0, build_wall = wall_seconds() - w0;
    if (rays.empty()) rays = incoherent_rays(tracer.bounds_lower(), tracer.bounds_upper(), 1 << 21, false, 5);
    std::vector<uint8_t> hit(rays.size());
    double best = 0;
    for (int rep = 0; rep < 3; ++rep) {  // the fastest of 3: the least disturbed by other processes
      const double t0 = cpu_seconds();
      tbb::parallel_for(tbb::blocked_range<size_t>(0, rays.size(), 1024), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i < r.end(); ++i) hit[i] = tracer.intersect_id(rays[i]).has_value();
      });
      best = std::max(best, static_cast<double>(rays.size()) / (cpu_seconds() - t0) * 1e-6);
    }
    size_t hits = 0;
    for (uint8_t h : hit) hits += h;
    std::printf("%-17s %9.2f %9.2f %11.1f %11zu %11zu %12.2f %9.3f\n", name(inst), build_cpu, build_wall,
                tracer.memory_bytes() / 1048576.0, tracer.triangle_count(), tracer.stored_triangle_count(), best,
                static_cast<double>(hits) / rays.size());
  }
}

void bake_and_report(const char* what, lightmap::LightmapBakeInput in) {
  const double c0 = cpu_seconds(), w0 = wall_seconds();
  lightmap::LightmapBakeResult r;
  // The outputs stream out page by page as kilnd takes them (its store writes each one): counted here and let go,
  // so that the bake's memory plan and the process's peak RSS are a daemon's.
  bake::BakeControl control;
  std::string report_bytes;
  uint64_t output_bytes = 0;
  control.output_sink = [&](bake::BakeOutput&& o) {
    output_bytes += o.bytes.size();
    if (o.name == "report.json") report_bytes = std::move(o.bytes);
  };
  try {
    r = lightmap::bake_lightmaps(in, control);
  } catch (const bake::InvalidInput& e) {  // the time limit ran out in the set-up: say where
    std::printf("\n%s: failed after %.1f s wall, %.1f s CPU: %s: %s\n", what, wall_seconds() - w0, cpu_seconds() - c0,
                e.field().c_str(), e.problem().c_str());
    return;
  }
  const double cpu = cpu_seconds() - c0, wall = wall_seconds() - w0;
  const nlohmann::json report = nlohmann::json::parse(report_bytes);
  double texels = 0;
  size_t lightmaps = 0;
  for (const auto& m : report["lightmaps"]) {
    texels += m["valid_texels"].get<double>();
    ++lightmaps;
  }
  double probed = 0, pruned = 0;
  for (const auto& m : report["lightmaps"]) {
    probed += m["leaks"]["probed"].get<double>();
    pruned += m["leaks"]["pruned"].get<double>();
  }
  const double passes = [&] {
    for (const auto& st : report["stages"])
      if (st["stage"] == "passes") return st["seconds"].get<double>();
    return 0.0;
  }();
  std::printf("\n%s: %zu lightmaps, %.0f valid texels, %.1f s wall, %.1f s CPU, %.1f MB of outputs streamed\n", what,
              lightmaps, texels, wall, cpu, output_bytes / 1048576.0);
  std::printf("  samples %llu, rays %llu (leak probes %llu), error estimate %s\n",
              static_cast<unsigned long long>(r.samples), static_cast<unsigned long long>(r.rays),
              static_cast<unsigned long long>(r.probe_rays),
              r.error_estimate >= 0 ? std::to_string(r.error_estimate).c_str() : "unknown");
  std::printf("  leak probes: %.0f sample points probed, %.0f pruned; tracer %.1f MB, %s triangles traced, %s held\n",
              probed, pruned, report["tracer"]["memory_bytes"].get<double>() / 1048576.0,
              report["tracer"]["triangles"].dump().c_str(), report["tracer"]["stored_triangles"].dump().c_str());
  for (const auto& m : report["lightmaps"]) {
    if (!m.contains("seams")) continue;
    std::printf("  seams of %s: %s\n", m["name"].get<std::string>().c_str(), m["seams"].dump().c_str());
  }
  const auto& scope = report["leak_scope"];
  std::printf("  leak scope: meshes convex %s, height fields %s, closed star-shaped %s, probed everywhere %s\n",
              scope["convex_meshes"].dump().c_str(), scope["height_field_meshes"].dump().c_str(),
              scope["star_shaped_meshes"].dump().c_str(), scope["probed_meshes"].dump().c_str());
  if (report.contains("atlas")) {
    const auto& at = report["atlas"];
    std::printf(
        "  atlas: %s pages, %zu instances packed, density scale %s, chart area %.3f and valid texels %.3f "
        "of the pages' texels, packed in %.2f s\n",
        at["pages"].dump().c_str(), at["regions"].size(), at["density_scale"].dump().c_str(),
        at["efficiency"]["chart_area"].get<double>(), at["efficiency"]["valid_texels"].get<double>(),
        at["seconds"].get<double>());
  }
  if (report.contains("memory")) std::printf("  memory: %s\n", report["memory"].dump().c_str());
  if (report.contains("time_budget")) std::printf("  time budget: %s\n", report["time_budget"].dump().c_str());
  std::printf("  %-22s %9s %9s\n", "stage", "seconds", "fraction");
  for (const auto& st : report["stages"])
    std::printf("  %-22s %9.3f %9.3f\n", st["stage"].get<std::string>().c_str(), st["seconds"].get<double>(),
                st["fraction"].get<double>());
  if (passes > 0) {
    std::printf(
        "  rate in the passes: %.3g samples/s, %.3g texels/s (valid texels over the passes' seconds), %.3g "
        "rays/s over the bake\n",
        r.samples / passes, texels / passes, r.rays / std::max(r.seconds, 1e-9));
  }
}

// The atlas pages of the bake's input alone: their count and sides, and the charts' texels over the pages' texels.
void pack_and_report(const lightmap::LightmapBakeInput& in) {
  const double c0 = cpu_seconds();
  lightmap::AtlasPack pack;
  lightmap::check_and_pack_scene(in.scene, in.atlas, {}, pack);
  std::string sides;
  for (const lightmap::AtlasPage& p : pack.pages) sides += (sides.empty() ? "" : " ") + std::to_string(p.size);
  size_t packed = 0;
  for (const lightmap::AtlasRegion& r : pack.regions) packed += r.page >= 0;
  std::printf(
      "\natlas at %g texels/m, pages of %d^2 at most, padding %d%s: %zu pages (sides %s), %zu instances "
      "packed, density scale %g, chart area %.3f of the pages' %.0f texels; %.2f s CPU with the scene check\n",
      in.atlas.texel_density, in.atlas.page_size, pack.padding, in.atlas.uniform_pages ? ", uniform" : "",
      pack.pages.size(), sides.c_str(), packed, pack.density_scale, lightmap::chart_area_fraction(pack),
      lightmap::page_texels(pack), cpu_seconds() - c0);
}

lightmap::LightmapBakeInput short_bake(scene::Scene s, int resolution, double time_limit) {
  lightmap::LightmapBakeInput in;
  in.scene = std::move(s);
  in.resolution = resolution;
  in.target_error = 0.05;
  in.min_samples = 1;
  in.max_samples = 64;
  in.padding = 2;
  in.preview = false;
  in.time_limit_seconds = time_limit;
  return in;
}

}  // namespace
}  // namespace kiln::bench

int main(int argc, char** argv) {
  using namespace kiln;
  const bench::Args a = bench::parse(argc, argv);
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // each line as it is measured, also into a file
  if (!a.skip_level) {
    const scene::Scene level = bench::level_scene(a.level);
    size_t world = 0, distinct = 0;
    for (const scene::Instance& i : level.instances) world += level.meshes[i.mesh].indices.size() / 3;
    for (const scene::Mesh& m : level.meshes) distinct += m.indices.size() / 3;
    std::printf("level: %zu meshes (%zu distinct triangles), %zu instances, %zu triangles in world space, seed %llu\n",
                level.meshes.size(), distinct, level.instances.size(), world,
                static_cast<unsigned long long>(a.level.seed));
    const double c0 = bench::cpu_seconds();
    const scene::CheckedScene checked = scene::check_scene(level);
    std::printf("scene check: %.2f s CPU, %lld problems\n", bench::cpu_seconds() - c0,
                static_cast<long long>(checked.report.total()));
    if (!a.skip_tracers) bench::tracers(checked.scene);
    lightmap::LightmapBakeInput in = bench::short_bake(level, a.prop_resolution, a.time_limit);
    in.memory_limit_bytes = a.limit;
    if (a.texel_density > 0) {
      for (scene::Instance& i : in.scene.instances) {
        i.lightmap.clear();
        i.lightmap_scale_offset = {1, 1, 0, 0};
      }
      in.atlas.texel_density = a.texel_density;
      in.atlas.page_size = a.page_size;
      in.atlas.max_pages = a.max_pages;
      in.atlas.padding = in.padding;
    } else {
      in.resolutions["terrain"] = a.terrain_resolution;
    }
    if (a.pack_only && a.texel_density > 0) {
      bench::pack_and_report(in);
      in.atlas.uniform_pages = true;
      bench::pack_and_report(in);
    } else {
      bench::bake_and_report("level bake", in);
    }
  }
  if (!a.skip_terrain) {
    bench::LevelOptions o;
    o.terrain_quads = a.terrain_quads;
    o.meshes = o.instances = 0;
    const scene::Scene terrain = bench::level_scene(o);
    std::printf("\nterrain: %zu triangles at 1024², time limit %.0f s\n", terrain.meshes[0].indices.size() / 3,
                a.time_limit);
    bench::bake_and_report("terrain bake", bench::short_bake(terrain, 1024, a.time_limit));
  }
  return 0;
}
