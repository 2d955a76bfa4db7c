// What lightmap accuracy costs in time, and how fast the baker traces: the bundled Cornell box
// (client/examples/scenes/cornell_box.py, built in code by tests/support/test_scenes.h: 8 lightmaps) baked at
// increasing sample budgets, at the default target error, and planned against a full simulation; then raw Embree
// rays of the same kind in the same process, for the baker's ray throughput as a ratio of raw Embree's.
//
//   lightmap_bench [--table_out=FILE] [--quick] [--resolution=N]
//
// Plain timing with a custom main (a bake is seconds long, so Google Benchmark's repetition machinery adds nothing),
// both cores through TBB, in wall-clock seconds (steady_clock) and CPU seconds of the whole process (all threads).
// Every measured bake runs 3 times (the reference once), each followed at once by its raw-Embree run, and the fastest
// of each is kept (see bake()): on a shared machine a single run's ratio moves by ±10 % between runs, the fastest of
// three far less. Default: 32² per lightmap, 4096-estimate reference; --quick: 16², 1024-estimate reference and
// target 0.05 for the planner lines. Most of the time is the reference and the default-target bake (~4000 estimates
// per texel: this scene's small light makes one estimate's relative standard deviation ~0.5). The default takes ~13
// CPU-minutes (6.5 minutes on two cores), --quick a fraction of that.
//
// Budgets: max_samples 4 … 256 with min_samples = max_samples and a target error of 1e-4 that no texel reaches, so
// the budget binds and every valid texel gets exactly that many estimates. "est. error" is the bake's own estimate
// (RMS over valid texels of the relative standard error of the mean luminance, report.json's error_estimate); "error
// vs ref" is the RMS over valid texels of |Y − Y_ref| / Y_ref, Y the luminance of the irradiance.
//
// The curve under the default metric: targets 0.08, 0.04, 0.02, 0.01 (--quick: 0.1, 0.05) with error_metric lightmap,
// as the plan has it (light tracing on) and with light tracing forced off (every texel gathers all its light: the
// sampling before light tracing), each the fastest of 3 in CPU time; the error against the reference under the same
// metric, and the ratio of 1 / (error² · CPU s) between the two: how much less time light tracing takes for the same
// error, measured in one process.
//
// The reference: a bake of 4096 estimates per texel (1024 with --quick) with another seed, computed once at the start
// of the run (not cached: a stale reference from an older baker would silently measure the wrong thing). Its own
// error e_ref (~1/√16 or 1/√4 of the 256-sample bake's) is independent of each bake's and adds in quadrature, so
// "error vs ref" reads sqrt(e² + e_ref²); "(ref removed)" is sqrt(error vs ref² − e_ref²), the bake's own error, to
// compare with "est. error" (it is meaningful only well above e_ref).
//
// Raw Embree: the baker's own rays, replayed. A 16-estimate bake of the box (another seed) records every ray it
// traces (bakers/lightmap/ray_log.h): the transport's (origins on the surfaces, cosine- and BSDF-sampled directions,
// shadow rays ending on the light) and the leak probes' (every sample point's hemisphere, before the passes). Each
// measured bake is followed by the same number of rays as it traced, with its own mix of the three kinds (transport
// closest-hit, shadow, leak probe), each cycled through its recorded rays in their recorded order and traced one at
// a time through Tracer::intersect_id and Tracer::occluded (rtcIntersect1 / rtcOccluded1 and nothing else worth
// counting) on both cores with TBB, over the same Tracer (robust mode, as the baker's). The ratio divides the
// baker's rays per second of its whole bake (rasterization, leaks, outputs included) by raw Embree's: the share of
// the bake's time spent inside Embree (docs/PERFORMANCE.md says why the baseline replays the baker's own rays rather
// than synthetic ones). The leak probes are most of a short bake's rays (58 % at 4 estimates per texel) and cost the
// baker little beyond Embree's query, which is why the short bakes' ratio is the highest.
//
//   lightmap_bench --profile=N [--bake_only]
//                                only the N-estimate budget bake and its baseline (no reference, no table): for
//                                comparing two builds quickly; --bake_only leaves the baseline out, for profiling the
//                                baker alone.
//   lightmap_bench --subdivide=K  the same box with every triangle split into 4^K (edge midpoints, every attribute
//                                interpolated): the same surfaces with 32·4^K triangles, for the ratio on heavier
//                                geometry (the rasterizer then places more sample points per texel, so a bake traces
//                                more rays per texel; Embree's cost per query and the baker's both grow).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <string>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "bakers/lightmap/lightmap_bake.h"
#include "bakers/lightmap/ray_log.h"
#include "bakers/scene/scene_check.h"
#include "bakers/scene/tracer.h"
#include "tests/bench/table_file.h"
#include "tests/support/test_scenes.h"

namespace kiln::lightmap {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Per lightmap, per texel: the luminance of the irradiance, NaN where invalid.
using Luminances = std::vector<std::vector<double>>;

double process_cpu_seconds() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

struct Timing {
  double wall = 0, cpu = 0;
};

// The baker's own rays, recorded by a bake (bakers/lightmap/ray_log.h) and split by kind, each kind in the order
// the bake traced it: what raw Embree replays.
struct RayPools {
  std::vector<scene::Ray> closest, occlusion, probe;
};

RayPools record_rays(LightmapBakeInput in) {
  constexpr size_t kCapacity = size_t{1} << 22;  // 4 M rays, ~230 MB: every ray of the recording bake at 32²
  RayLog log(kCapacity);
  in.ray_log = &log;
  bake_lightmaps(in);
  RayPools pools;
  for (size_t i = 0; i < log.size(); ++i) {
    switch (log.kind(i)) {
      case RayKind::closest:
        pools.closest.push_back(log.ray(i));
        break;
      case RayKind::occlusion:
        pools.occlusion.push_back(log.ray(i));
        break;
      case RayKind::probe:
        pools.probe.push_back(log.ray(i));
        break;
    }
  }
  return pools;
}

// How many rays of each kind a bake traced.
struct RayMix {
  uint64_t closest = 0, occlusion = 0, probe = 0;
};
RayMix mix_of(const LightmapBakeResult& r) {
  return {r.rays - r.occlusion_rays - r.probe_rays, r.occlusion_rays, r.probe_rays};
}

// Raw Embree: `mix` rays, each kind cycled through its pool, one at a time, on every TBB thread.
Timing raw_embree_seconds(const scene::Tracer& tracer, const RayPools& pools, const RayMix& mix) {
  std::atomic<uint64_t> hits{0};
  const uint64_t end_closest = mix.closest, end_occlusion = end_closest + mix.occlusion,
                 end_probe = end_occlusion + mix.probe;
  const auto t0 = Clock::now();
  const double cpu0 = process_cpu_seconds();
  tbb::parallel_for(tbb::blocked_range<uint64_t>(0, end_probe, 1024), [&](const tbb::blocked_range<uint64_t>& r) {
    uint64_t h = 0;
    // The part of this block in [begin, end), walked through `pool` from the block's own start, wrapping by
    // comparison (a modulo per ray would cost as much as a tenth of an Embree query and count against Embree).
    auto replay = [&](const std::vector<scene::Ray>& pool, uint64_t begin, uint64_t end, auto&& trace) {
      const uint64_t lo = std::max(r.begin(), begin), hi = std::min(r.end(), end);
      if (lo >= hi) return;
      size_t k = (lo - begin) % pool.size();
      for (uint64_t i = lo; i < hi; ++i) {
        h += trace(pool[k]);
        if (++k == pool.size()) k = 0;
      }
    };
    auto closest_hit = [&](const scene::Ray& ray) { return tracer.intersect_id(ray).has_value(); };
    replay(pools.closest, 0, end_closest, closest_hit);
    replay(pools.occlusion, end_closest, end_occlusion, [&](const scene::Ray& ray) { return tracer.occluded(ray); });
    replay(pools.probe, end_occlusion, end_probe, closest_hit);
    hits.fetch_add(h, std::memory_order_relaxed);
  });
  const Timing s{seconds_since(t0), process_cpu_seconds() - cpu0};
  if (hits.load() == 0) std::fprintf(stderr, "raw Embree: no ray hit anything (the scene is wrong)\n");
  return s;
}

struct Run {
  std::string label;
  LightmapBakeResult result;
  Luminances Y;
  double cpu_seconds = 0;  // of the whole process (all threads) during the bake
  Timing raw;              // raw Embree on the bake's ray count and mix, measured right after it
};

// The bake `repeats` times (the same bytes each time), each followed at once by raw Embree on its ray count and mix;
// the fastest of each. The machine this runs on is shared: measuring the two back to back and keeping the best of a
// few keeps other load out of the ratio (measured apart, it moved by ±30 % between runs).
Run timed_bake(const std::string& label, LightmapBakeInput in, const RayPools& pools, int repeats = 1,
               bool with_baseline = true) {
  Run run{label, {}, {}, INFINITY, {INFINITY, INFINITY}};
  for (int i = 0; i < repeats; ++i) {
    const double cpu0 = process_cpu_seconds();
    LightmapBakeResult r = bake_lightmaps(in);
    const double cpu = process_cpu_seconds() - cpu0;
    if (cpu < run.cpu_seconds) {
      run.cpu_seconds = cpu;
      run.result = std::move(r);
    }
    if (!with_baseline) continue;
    const scene::CheckedScene checked = scene::check_scene(in.scene);
    const scene::Tracer tracer(checked.scene);
    const Timing t = raw_embree_seconds(tracer, pools, mix_of(run.result));
    run.raw.wall = std::min(run.raw.wall, t.wall);
    run.raw.cpu = std::min(run.raw.cpu, t.cpu);
  }
  for (const bake::BakeOutput& o : run.result.outputs) {
    const std::string suffix = "_irradiance.exr";
    if (o.name.size() <= suffix.size() || o.name.compare(o.name.size() - suffix.size(), suffix.size(), suffix) != 0)
      continue;
    const std::string name = o.name.substr(0, o.name.size() - suffix.size());
    const image::FloatImage E = image::decode_exr(o.bytes);
    const image::FloatImage valid = test::exr_output(run.result, name + "_validity.exr");
    std::vector<double> Y(static_cast<size_t>(E.width) * E.height, std::nan(""));
    for (size_t t = 0; t < Y.size(); ++t) {
      if (valid.pixels[t * valid.channels] > 0.5f) {
        Y[t] = luminance(Rgb{E.pixels[3 * t], E.pixels[3 * t + 1], E.pixels[3 * t + 2]});
      }
    }
    run.Y.push_back(std::move(Y));
  }
  return run;
}

// RMS over texels valid in both of the relative luminance difference. Every valid texel of the box receives light
// (directly or by one bounce), so Y_ref > 0; a texel where it is not is skipped rather than divided by.
double error_vs(const Luminances& a, const Luminances& ref) {
  double sum = 0;
  size_t n = 0;
  for (size_t m = 0; m < std::min(a.size(), ref.size()); ++m) {
    for (size_t t = 0; t < std::min(a[m].size(), ref[m].size()); ++t) {
      if (!std::isfinite(a[m][t]) || !std::isfinite(ref[m][t]) || !(ref[m][t] > 0)) continue;
      const double e = (a[m][t] - ref[m][t]) / ref[m][t];
      sum += e * e;
      ++n;
    }
  }
  return n ? std::sqrt(sum / n) : NAN;
}

// The error under the default metric (error_metric.h): per lightmap, (Y − Y_ref) / B_ref with B_ref the mean
// luminance of the reference's valid texels, RMS over the texels valid in both (every lightmap's texels together, as
// report.json's error_estimate).
double lightmap_error_vs(const Luminances& a, const Luminances& ref) {
  double sum = 0;
  size_t n = 0;
  for (size_t m = 0; m < std::min(a.size(), ref.size()); ++m) {
    double b = 0;
    size_t valid = 0;
    for (const double y : ref[m]) {
      if (std::isfinite(y)) b += y, ++valid;
    }
    if (!(b > 0)) continue;
    b /= static_cast<double>(valid);
    for (size_t t = 0; t < std::min(a[m].size(), ref[m].size()); ++t) {
      if (!std::isfinite(a[m][t]) || !std::isfinite(ref[m][t])) continue;
      const double e = (a[m][t] - ref[m][t]) / b;
      sum += e * e;
      ++n;
    }
  }
  return n ? std::sqrt(sum / n) : NAN;
}

// The reference's own error under the default metric, from its error images (texel metric: the standard error over
// the texel's own luminance, well above the error floor in the box): RMS of σ_t / B_ref.
double reference_lightmap_error(const Run& reference) {
  double sum = 0;
  size_t n = 0;
  size_t m = 0;
  for (const bake::BakeOutput& o : reference.result.outputs) {
    const std::string suffix = "_error.exr";
    if (o.name.size() <= suffix.size() || o.name.compare(o.name.size() - suffix.size(), suffix.size(), suffix) != 0)
      continue;
    const image::FloatImage error = image::decode_exr(o.bytes);
    const std::vector<double>& Y = reference.Y.at(m++);
    double b = 0;
    size_t valid = 0;
    for (const double y : Y) {
      if (std::isfinite(y)) b += y, ++valid;
    }
    if (!(b > 0)) continue;
    b /= static_cast<double>(valid);
    for (size_t t = 0; t < Y.size(); ++t) {
      if (!std::isfinite(Y[t])) continue;
      const double sigma = error.pixels[t * error.channels] * Y[t];
      sum += (sigma / b) * (sigma / b);
      ++n;
    }
  }
  return n ? std::sqrt(sum / n) : NAN;
}

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

// Every triangle of every mesh split into 4 at its edge midpoints, `levels` times, each attribute interpolated
// linearly (the surfaces, their UVs and normals are unchanged). Vertices are not shared between triangles: this is
// for loading Embree with triangles, not for memory.
void subdivide(scene::Scene& scene, int levels) {
  for (scene::Mesh& mesh : scene.meshes) {
    for (int level = 0; level < levels; ++level) {
      scene::Mesh out;
      out.name = mesh.name;
      auto mid = [](auto a, auto b) { return decltype(a){(a.x + b.x) / 2, (a.y + b.y) / 2}; };
      auto vertex = [&](uint32_t i, uint32_t j) {  // the midpoint of vertices i and j (i == j: vertex i)
        out.positions.push_back((mesh.positions[i] + mesh.positions[j]) * 0.5);
        if (!mesh.normals.empty()) out.normals.push_back((mesh.normals[i] + mesh.normals[j]) * 0.5);
        if (!mesh.uv.empty()) out.uv.push_back(mid(mesh.uv[i], mesh.uv[j]));
        if (!mesh.lightmap_uv.empty()) out.lightmap_uv.push_back(mid(mesh.lightmap_uv[i], mesh.lightmap_uv[j]));
        return static_cast<uint32_t>(out.positions.size() - 1);
      };
      for (size_t t = 0; t * 3 < mesh.indices.size(); ++t) {
        const uint32_t a = mesh.indices[3 * t], b = mesh.indices[3 * t + 1], c = mesh.indices[3 * t + 2];
        const uint32_t va = vertex(a, a), vb = vertex(b, b), vc = vertex(c, c);
        const uint32_t ab = vertex(a, b), bc = vertex(b, c), ca = vertex(c, a);
        for (uint32_t i : {va, ab, ca, ab, vb, bc, ca, bc, vc, ab, bc, ca}) out.indices.push_back(i);
        if (!mesh.material.empty()) out.material.insert(out.material.end(), 4, mesh.material[t]);
      }
      mesh = std::move(out);
    }
  }
}

}  // namespace
}  // namespace kiln::lightmap

int main(int argc, char** argv) {
  using namespace kiln;
  using namespace kiln::lightmap;
  bool quick = false;
  int resolution = 0, profile = 0, subdivisions = 0;
  bool bake_only = false;
  std::string table_out, command = "lightmap_bench";
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--quick") == 0) {
      quick = true;
      command += " --quick";
    } else if (std::strncmp(argv[i], "--table_out=", 12) == 0) {
      table_out = argv[i] + 12;
    } else if (std::strncmp(argv[i], "--resolution=", 13) == 0) {
      resolution = std::atoi(argv[i] + 13);
      command += std::string(" ") + argv[i];
    } else if (std::strncmp(argv[i], "--profile=", 10) == 0) {
      profile = std::atoi(argv[i] + 10);
    } else if (std::strcmp(argv[i], "--bake_only") == 0) {
      bake_only = true;
    } else if (std::strncmp(argv[i], "--subdivide=", 12) == 0) {
      subdivisions = std::clamp(std::atoi(argv[i] + 12), 0, 8);
      command += std::string(" ") + argv[i];
    } else {
      std::fprintf(stderr,
                   "usage: lightmap_bench [--table_out=FILE] [--quick] [--resolution=N] [--subdivide=K] "
                   "[--profile=N [--bake_only]]\n");
      return 2;
    }
  }
  if (resolution <= 0) resolution = quick ? 16 : 32;
  const uint64_t reference_samples = quick ? 1024 : 4096;

  // The box, subdivided once; every bake input takes a copy.
  const scene::Scene box = [&] {
    scene::Scene s = test::cornell_box();
    subdivide(s, subdivisions);
    return s;
  }();
  auto input = [&](uint64_t samples, double target, uint64_t seed) {
    LightmapBakeInput in = test::lightmap_input(box, resolution, target);
    in.min_samples = std::min<uint64_t>(samples, in.min_samples);
    in.max_samples = samples;
    in.seed = seed;
    return in;
  };
  auto budget = [&](uint64_t samples, uint64_t seed) {
    LightmapBakeInput in = input(samples, 1e-4, seed);
    in.min_samples = samples;  // every valid texel gets exactly `samples` estimates
    return in;
  };

  size_t triangles = 0;
  for (const scene::Mesh& m : box.meshes) triangles += m.indices.size() / 3;
  std::fprintf(stderr, "the box: %zu triangles\n", triangles);

  // The baseline's rays: every ray of a 16-estimate bake of the box (another seed than the bakes measured).
  RayPools pools;
  if (!(profile > 0 && bake_only)) {
    std::fprintf(stderr, "recording the baker's rays...\n");
    pools = record_rays(budget(16, 424242));
    std::fprintf(stderr, "recorded %zu closest-hit, %zu shadow and %zu leak-probe rays\n", pools.closest.size(),
                 pools.occlusion.size(), pools.probe.size());
    if (pools.closest.empty() || pools.occlusion.empty() || pools.probe.empty()) {
      std::fprintf(stderr, "lightmap_bench: the recording bake traced no rays of some kind; the box is wrong\n");
      return 1;
    }
  }
  if (profile > 0) {
    // One budget bake and its baseline, for profiling and quick comparisons: no reference, no table.
    const Run r = timed_bake("profile", budget(profile, 1), pools, 3, !bake_only);
    if (bake_only) {
      std::printf("budget %d: %.3f CPU s, %llu rays, %.2f Mrays/cpu_s\n", profile, r.cpu_seconds,
                  static_cast<unsigned long long>(r.result.rays), r.result.rays / r.cpu_seconds * 1e-6);
      return 0;
    }
    std::printf(
        "budget %d: %.3f CPU s, %llu rays, %.2f Mrays/cpu_s; raw Embree %.2f Mrays/cpu_s; ratio (CPU) %.3f, "
        "(wall) %.3f\n",
        profile, r.cpu_seconds, static_cast<unsigned long long>(r.result.rays), r.result.rays / r.cpu_seconds * 1e-6,
        r.result.rays / r.raw.cpu * 1e-6, r.raw.cpu / r.cpu_seconds, r.raw.wall / r.result.seconds);
    return 0;
  }

  std::fprintf(stderr, "reference: %llu estimates per texel at %d^2...\n",
               static_cast<unsigned long long>(reference_samples), resolution);
  const Run reference = timed_bake("reference", budget(reference_samples, 987654321), pools);

  std::vector<Run> runs;
  for (const uint64_t n : {4, 16, 64, 256}) {
    std::fprintf(stderr, "budget %llu...\n", static_cast<unsigned long long>(n));
    runs.push_back(timed_bake("max_samples " + std::to_string(n), budget(n, 1), pools, 3));
  }
  std::fprintf(stderr, "default target...\n");
  runs.push_back(timed_bake("target 0.01 (default)", input(4096, 0.01, 1), pools, 3));
  // The planner: the same target, planned and as a full simulation (every effect, max_bounces bounces), on the box
  // as `kiln bake lightmap` imports it from the glTF: every material gets glTF's dielectric coat, GGX with α =
  // roughness² = 1 and Schlick's f0 = 0.04, layered over the tinted Lambertian base (client/import/scene_import.cpp).
  // A coat that rough reflects almost like Lambert: the planner replaces it by a Lambertian lobe of its albedo and
  // shades the material in closed form; the full simulation shades the layered GGX material.
  const double plan_target = quick ? 0.05 : 0.02;
  auto imported = [&](uint64_t samples, double target, uint64_t seed) {
    LightmapBakeInput in = input(samples, target, seed);
    for (scene::SceneMaterial& m : in.scene.materials) {
      m.bsdf.specular = brdf::ModelSpec{};
      m.bsdf.specular.model = brdf::Model::ggx;
      m.bsdf.specular.alpha_x = m.bsdf.specular.alpha_y = 1.0;
      m.bsdf.specular.fresnel = brdf::FresnelMode::schlick;
      m.bsdf.specular.f0 = Rgb{0.04};
      m.bsdf.combine = brdf::Combine::layered;
    }
    return in;
  };
  // Error against time under the default metric: light tracing (the plan's default) against light tracing forced off
  // (every texel gathers all its light, as every bake did before it), at the same targets, fastest of 3 each.
  std::vector<std::pair<Run, Run>> curve;
  for (const double target : quick ? std::vector<double>{0.1, 0.05} : std::vector<double>{0.08, 0.04, 0.02, 0.01}) {
    std::fprintf(stderr, "default metric, target %.2f, with and without light tracing...\n", target);
    LightmapBakeInput in = input(4096, target, 1);
    in.error_metric = ErrorMetric::lightmap;
    LightmapBakeInput off = in;
    off.force_effects["light_tracing"] = false;
    curve.emplace_back(timed_bake("target " + fmt("%.2f", target), in, pools, 3, false),
                       timed_bake("target " + fmt("%.2f", target), off, pools, 3, false));
  }
  std::fprintf(stderr, "planned vs full simulation...\n");
  const Run planned =
      timed_bake("imported box, planned, target " + fmt("%.2f", plan_target), imported(4096, plan_target, 1), pools, 3);
  LightmapBakeInput full_in = imported(4096, plan_target, 1);
  full_in.full_simulation = true;
  const Run full = timed_bake("imported box, full simulation, target " + fmt("%.2f", plan_target), full_in, pools, 3);

  std::string table;
  auto line = [&](const std::string& s) { table += s + "\n"; };
  line("Cornell box (client/examples/scenes/cornell_box.py, 8 lightmaps, " + std::to_string(triangles) +
       " triangles), " + std::to_string(resolution) +
       "^2 per "
       "lightmap; reference: " +
       std::to_string(reference_samples) + " estimates per texel, its own estimated error " +
       fmt("%.4f", reference.result.error_estimate) + ", " + fmt("%.1f s", reference.result.seconds) + ".");
  line("");
  line(
      "| bake | time (s) | CPU (s) | samples | rays | occl. | Mrays/s | Mrays/cpu_s | est. error | error vs ref | "
      "(ref removed) | raw Embree Mrays/s | Mrays/cpu_s | ratio (wall) | ratio (CPU) |");
  line("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
  const double e_ref = reference.result.error_estimate;
  auto row = [&](const Run& r) {
    const LightmapBakeResult& b = r.result;
    const Timing& raw_s = r.raw;
    const double mrays = b.rays / b.seconds * 1e-6, raw = b.rays / raw_s.wall * 1e-6;
    const double mrays_cpu = b.rays / r.cpu_seconds * 1e-6, raw_cpu = b.rays / raw_s.cpu * 1e-6;
    // The imported box has other materials than the reference: no error against it.
    const bool comparable = r.label.rfind("imported", 0) != 0;
    const double e = comparable ? error_vs(r.Y, reference.Y) : NAN;
    line("| " + r.label + " | " + fmt("%.2f", b.seconds) + " | " + fmt("%.2f", r.cpu_seconds) + " | " +
         std::to_string(b.samples) + " | " + std::to_string(b.rays) + " | " +
         fmt("%.0f%%", 100.0 * b.occlusion_rays / std::max<uint64_t>(b.rays, 1)) + " | " + fmt("%.2f", mrays) + " | " +
         fmt("%.2f", mrays_cpu) + " | " + fmt("%.4f", b.error_estimate) + " | " +
         (comparable ? fmt("%.4f", e) : "n/a") + " | " +
         (comparable ? fmt("%.4f", std::sqrt(std::max(0.0, e * e - e_ref * e_ref))) : "n/a") + " | " +
         fmt("%.2f", raw) + " | " + fmt("%.2f", raw_cpu) + " | " + fmt("%.2f", mrays / raw) + " | " +
         fmt("%.2f", mrays_cpu / raw_cpu) + " |");
  };
  for (const Run& r : runs) row(r);
  row(planned);
  row(full);
  line("");
  line("Planned vs full simulation of the imported box (GGX coat α = 1, f0 = 0.04) at target " +
       fmt("%.2f", plan_target) + ": CPU " + fmt("%.2f", planned.cpu_seconds) + " s vs " +
       fmt("%.2f", full.cpu_seconds) + " s (full/planned " + fmt("%.2fx", full.cpu_seconds / planned.cpu_seconds) +
       "), rays " + std::to_string(planned.result.rays) + " vs " + std::to_string(full.result.rays) +
       ", vertices shaded through the general BSDF " + std::to_string(planned.result.general_vertices) + " vs " +
       std::to_string(full.result.general_vertices) + "; planned vs full " + fmt("%.4f", error_vs(planned.Y, full.Y)) +
       " (RMS relative luminance difference; their estimated errors " + fmt("%.4f", planned.result.error_estimate) +
       " and " + fmt("%.4f", full.result.error_estimate) + ", so within noise if below about " +
       fmt("%.4f", std::hypot(planned.result.error_estimate, full.result.error_estimate)) + ").");
  line("");
  const double e_ref_lightmap = reference_lightmap_error(reference);
  line(
      "Error against time under the default metric (a texel's error over its lightmap's brightness), with light "
      "tracing and with it forced off (every texel gathers all its light); error vs ref under the same metric, the "
      "reference's own (" +
      fmt("%.4f", e_ref_lightmap) +
      ") removed in quadrature; efficiency = 1 / (error² · CPU "
      "s), off / on is how much less time light tracing needs for the same error.");
  line("");
  line(
      "| target | light tracing | time (s) | CPU (s) | samples | light rays | rays | est. error | error vs ref | "
      "(ref removed) | efficiency | off / on |");
  line("|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
  for (const auto& [on, off] : curve) {
    double efficiency[2];
    int i = 0;
    for (const Run* r : {&on, &off}) {
      const LightmapBakeResult& b = r->result;
      const double e =
          std::sqrt(std::max(0.0, std::pow(lightmap_error_vs(r->Y, reference.Y), 2) - e_ref_lightmap * e_ref_lightmap));
      efficiency[i] = 1 / (e * e * r->cpu_seconds);
      line("| " + r->label.substr(7) + " | " + (i == 0 ? "on" : "off") + " | " + fmt("%.2f", b.seconds) + " | " +
           fmt("%.2f", r->cpu_seconds) + " | " + std::to_string(b.samples) + " | " +
           std::to_string(b.light_tracing.light_rays) + " | " + std::to_string(b.rays) + " | " +
           fmt("%.4f", b.error_estimate) + " | " + fmt("%.4f", lightmap_error_vs(r->Y, reference.Y)) + " | " +
           fmt("%.4f", e) + " | " + fmt("%.0f", efficiency[i]) + " | " +
           (i == 1 ? fmt("%.2fx", efficiency[0] / efficiency[1]) : "") + " |");
      ++i;
    }
  }
  line("");
  line("Command: " + command + " (" + std::to_string(tbb::this_task_arena::max_concurrency()) + " TBB threads)");
  std::fputs(table.c_str(), stdout);
  return kiln::bench::write_table_file(table, table_out);
}
