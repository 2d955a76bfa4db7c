// Raw ray throughput of the Embree tracer (bakers/scene/tracer.h) on a generated box room (inward walls, a sphere, two
// transformed blocks: ~5,700 triangles) with incoherent rays (tests/bench/ray_workload.h): closest hit (the bare
// HitId, and the full Hit with normals and UVs), occlusion, one ray at a time and as Embree streams, on 1 and 2
// threads. Counters: Mrays/s, rays per wall-clock second; Mrays/cpu_s, rays per CPU-second of the process (all its
// threads), the figure to trust on a shared machine. This is the baseline the lightmap benchmark's ray throughput is
// compared against (use the same workload, tests/bench/ray_workload.h).
// Geometry (scene::Instancing): "robust" and "fast" trace the default (here every instance flattened: the room's two
// blocks share a mesh, but one copy of 192 triangles is below kInstancingMinCopies); "robust_flat" flattens every
// instance whatever the scene; "robust_all" makes every mesh an Embree instance of its own BVH (two-level traversal
// everywhere: what instancing costs a ray).
//
//   tracer_bench [--benchmark_filter=...] [Google Benchmark flags]
#include <benchmark/benchmark.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <ctime>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include "bakers/scene/scene_check.h"
#include "bakers/scene/tracer.h"
#include "tests/bench/ray_workload.h"
#include "tests/scene/tracer_geometry.h"

namespace kiln::scene {
namespace {

constexpr size_t kRays = 1 << 18;  // per iteration: enough to average over the whole room

struct Fixture {
  Tracer tracer;
  std::vector<Ray> closest, occlusion;
  Fixture(bool robust, Instancing instancing)
      : tracer(check_scene(test::box_room()).scene, TracerOptions{.robust = robust, .instancing = instancing}),
        closest(bench::incoherent_rays(tracer.bounds_lower(), tracer.bounds_upper(), kRays, false, 1)),
        occlusion(bench::incoherent_rays(tracer.bounds_lower(), tracer.bounds_upper(), kRays, true, 2)) {}
};

enum class Geometry { robust, fast, robust_flat, robust_all };

const Fixture& fixture(Geometry g) {
  switch (g) {
    case Geometry::fast: {
      static const Fixture f(false, Instancing::shared);
      return f;
    }
    case Geometry::robust_flat: {
      static const Fixture f(true, Instancing::none);
      return f;
    }
    case Geometry::robust_all: {
      static const Fixture f(true, Instancing::all);
      return f;
    }
    case Geometry::robust:
      break;
  }
  static const Fixture f(true, Instancing::shared);
  return f;
}

double process_cpu_seconds() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

enum class Query { closest_id, closest_full, occluded, closest_stream, occluded_stream };

// One iteration traces all kRays rays, split over `threads` TBB workers in chunks of 1024.
void trace(benchmark::State& state, Query query, Geometry geometry) {
  const int threads = static_cast<int>(state.range(0));
  const Fixture& f = fixture(geometry);
  const bool occ = query == Query::occluded || query == Query::occluded_stream;
  const std::vector<Ray>& rays = occ ? f.occlusion : f.closest;
  tbb::task_arena arena(threads);
  std::vector<uint8_t> hits(rays.size());
  const double cpu_start = process_cpu_seconds();
  for (auto _ : state) {
    arena.execute([&] {
      tbb::parallel_for(tbb::blocked_range<size_t>(0, rays.size(), 1024), [&](const tbb::blocked_range<size_t>& r) {
        switch (query) {
          case Query::closest_id:
            for (size_t i = r.begin(); i < r.end(); ++i) hits[i] = f.tracer.intersect_id(rays[i]).has_value();
            break;
          case Query::closest_full:
            for (size_t i = r.begin(); i < r.end(); ++i) hits[i] = f.tracer.intersect(rays[i]).has_value();
            break;
          case Query::occluded:
            for (size_t i = r.begin(); i < r.end(); ++i) hits[i] = f.tracer.occluded(rays[i]);
            break;
          case Query::closest_stream: {
            std::vector<std::optional<HitId>> out(r.size());
            f.tracer.intersect(std::span<const Ray>(rays.data() + r.begin(), r.size()), out);
            for (size_t i = 0; i < r.size(); ++i) hits[r.begin() + i] = out[i].has_value();
            break;
          }
          case Query::occluded_stream:
            f.tracer.occluded(std::span<const Ray>(rays.data() + r.begin(), r.size()),
                              std::span<uint8_t>(hits.data() + r.begin(), r.size()));
            break;
        }
      });
    });
    benchmark::DoNotOptimize(hits.data());
  }
  const double cpu_seconds = process_cpu_seconds() - cpu_start;
  size_t hit_count = 0;
  for (uint8_t h : hits) hit_count += h;
  state.counters["Mrays/s"] =
      benchmark::Counter(static_cast<double>(rays.size()) * state.iterations() * 1e-6, benchmark::Counter::kIsRate);
  // Per CPU-second of the whole process (all threads): what the tracer costs, independent of how much of the machine
  // other processes take (the wall-clock rate above is not, on a shared machine).
  state.counters["Mrays/cpu_s"] = static_cast<double>(rays.size()) * state.iterations() * 1e-6 / cpu_seconds;
  state.counters["hit_fraction"] = static_cast<double>(hit_count) / rays.size();
  state.counters["triangles"] = static_cast<double>(f.tracer.triangle_count());
  state.counters["memory_MB"] = static_cast<double>(f.tracer.memory_bytes()) / 1048576.0;
}

void register_all() {
  struct Entry {
    const char* name;
    Query query;
  };
  const Entry entries[] = {{"closest_id", Query::closest_id},
                           {"closest_full_hit", Query::closest_full},
                           {"occluded", Query::occluded},
                           {"closest_id_stream", Query::closest_stream},
                           {"occluded_stream", Query::occluded_stream}};
  const std::pair<Geometry, const char*> geometries[] = {{Geometry::robust, "/robust"},
                                                         {Geometry::fast, "/fast"},
                                                         {Geometry::robust_flat, "/robust_flat"},
                                                         {Geometry::robust_all, "/robust_all"}};
  for (const auto& [geometry, suffix] : geometries)
    for (const Entry& e : entries)
      benchmark::RegisterBenchmark((std::string("tracer/") + e.name + suffix).c_str(),
                                   [q = e.query, g = geometry](benchmark::State& s) { trace(s, q, g); })
          ->ArgName("threads")
          ->Arg(1)
          ->Arg(2)
          ->UseRealTime()
          ->Unit(benchmark::kMillisecond);
}

}  // namespace
}  // namespace kiln::scene

int main(int argc, char** argv) {
  kiln::scene::register_all();
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
