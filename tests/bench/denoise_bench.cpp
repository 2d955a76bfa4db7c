// What the lightmap denoiser (bakers/lightmap/denoise.h) buys and costs: the bundled Cornell box (tests/support/
// test_scenes.h, 8 lightmaps) baked with NAME_irradiance_denoised.exr at a few targets, the raw and the denoised
// lightmaps each against a high-sample reference, and the time for the same error; then the filter's time on the box's
// lightmaps at 1024².
//
//   denoise_bench [--table_out=FILE] [--resolution=N] [--reference=S] [--filter_resolution=N]
//                 [--sigma_luminance=X,...] [--sigma_normal=X,...] [--sigma_position=X,...] [--levels=N,...]
//
// Defaults: 64² per lightmap, a 4096-estimate reference, the filter's defaults, its time at 1024² (0: not measured).
// Lists of settings bake every combination, a table each (the raw columns repeat: the bakes are deterministic).
//
// Errors are the RMS over texels of |Y − Y_ref| / Y_ref (Y the luminance), over all valid texels and over the interior
// ones (their 3 × 3 neighbourhood valid: chart borders, where the filter's kernel is one-sided, left out). The
// reference is a bake of S estimates per texel (default 4096) with another seed; its own error e_ref adds in
// quadrature to a bake's error, bias included (the reference's noise is independent of both), so "(ref removed)" is
// sqrt(e² − e_ref²), meaningful well above e_ref. "raw time for that error" reads the raw bakes' error² × time
// (constant for Monte Carlo, fitted over the four raw bakes) at the denoised error; "time ratio" divides it by the
// denoised bake's wall time, denoising included.
//
// Times are wall-clock seconds of the whole bake on every TBB thread, CPU seconds of the process; the denoise column
// is report.json's (guides, filter, dilation and encoding of every lightmap). Each bake runs once: the errors do not
// move between runs, and the time ratios moved by 3 % at most between two runs of the default on a shared machine.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>
#include <vector>

#include <tbb/task_arena.h>

#include "bakers/image/exr.h"
#include "bakers/lightmap/denoise.h"
#include "bakers/lightmap/lightmap_bake.h"
#include "bakers/lightmap/lightmap_outputs.h"
#include "bakers/lightmap/lightmap_state.h"
#include "bakers/lightmap/texel_guides.h"
#include "bakers/math/rng.h"
#include "tests/support/test_scenes.h"
#include "tests/bench/table_file.h"

namespace kiln::lightmap {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

double process_cpu_seconds() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

const char* const kMaps[] = {"floor",      "ceiling",     "back_wall",  "left_wall",
                             "right_wall", "short_block", "tall_block", "light"};

// Per lightmap, per texel: the luminance, NaN where invalid or (for `interior`) on a chart's border.
using Luminances = std::vector<std::vector<double>>;

Luminances luminances(const LightmapBakeResult& r, const std::string& suffix, bool interior) {
  Luminances out;
  for (const char* name : kMaps) {
    const image::FloatImage E = test::exr_output(r, name + suffix);
    const image::FloatImage valid = test::exr_output(r, std::string(name) + "_validity.exr");
    std::vector<double> Y(static_cast<size_t>(E.width) * E.height, std::nan(""));
    for (int y = 0; y < E.height; ++y) {
      for (int x = 0; x < E.width; ++x) {
        bool keep = valid.at(x, y, 0) > 0.5f;
        for (int dy = -1; dy <= 1 && keep && interior; ++dy) {
          for (int dx = -1; dx <= 1 && keep; ++dx) {
            const int nx = x + dx, ny = y + dy;
            keep = nx >= 0 && ny >= 0 && nx < E.width && ny < E.height && valid.at(nx, ny, 0) > 0.5f;
          }
        }
        if (keep) Y[static_cast<size_t>(y) * E.width + x] = luminance(Rgb(E.at(x, y, 0), E.at(x, y, 1), E.at(x, y, 2)));
      }
    }
    out.push_back(std::move(Y));
  }
  return out;
}

double error_vs(const Luminances& a, const Luminances& ref) {
  double sum = 0;
  size_t n = 0;
  for (size_t m = 0; m < a.size(); ++m) {
    for (size_t t = 0; t < a[m].size(); ++t) {
      if (!std::isfinite(a[m][t]) || !std::isfinite(ref[m][t]) || !(ref[m][t] > 0)) continue;
      const double e = (a[m][t] - ref[m][t]) / ref[m][t];
      sum += e * e;
      ++n;
    }
  }
  return n ? std::sqrt(sum / n) : NAN;
}

// report.json's denoise.seconds (the bench links no JSON library: the key is unique in the report).
double denoise_seconds(const LightmapBakeResult& r) {
  const std::string& json = test::find_output(r, "report.json").bytes;
  const size_t at = json.find("\"seconds\"", json.find("\"denoise\""));
  return at == std::string::npos ? NAN : std::atof(json.c_str() + json.find(':', at) + 1);
}

struct Run {
  std::string label;
  double wall = 0, cpu = 0, denoise = 0;
  double raw_all = 0, raw_interior = 0, den_all = 0, den_interior = 0, den_vs_raw = 0;
};

struct Reference {
  Luminances all, interior;
  double error = 0;
};

Run measure(const std::string& label, const LightmapBakeInput& in, const Reference& ref) {
  const double cpu0 = process_cpu_seconds();
  const LightmapBakeResult r = bake_lightmaps(in);
  Run run{label, r.seconds, process_cpu_seconds() - cpu0, denoise_seconds(r)};
  const Luminances raw = luminances(r, "_irradiance.exr", false),
                   den = luminances(r, "_irradiance_denoised.exr", false);
  run.raw_all = error_vs(raw, ref.all);
  run.den_all = error_vs(den, ref.all);
  run.raw_interior = error_vs(luminances(r, "_irradiance.exr", true), ref.interior);
  run.den_interior = error_vs(luminances(r, "_irradiance_denoised.exr", true), ref.interior);
  run.den_vs_raw = error_vs(den, raw);
  std::fprintf(stderr, "%s: %.1f s, raw %.4f denoised %.4f (interior)\n", label.c_str(), run.wall, run.raw_interior,
               run.den_interior);
  return run;
}

// The denoised output's time on the box's lightmaps at `resolution`², with random estimates (the time hardly depends
// on the values): the guides and the filter alone, and the whole output as a bake spends it (guides, filter,
// dilation, EXR encoding).
struct FilterTime {
  size_t texels = 0;
  double guides = 0, filter = 0, output = 0;
};
FilterTime filter_seconds(const scene::Scene& box, int resolution, const DenoiseOptions& options) {
  FilterTime time;
  for (const char* name : kMaps) {
    RasterOptions raster;
    raster.width = raster.height = resolution;
    LightmapState m = make_lightmap_state(name, rasterize_lightmap(box, name, raster), LeakReport{}, false, false);
    Pcg32 rng(7);
    std::vector<Rgb> colour(m.image.texel_count());
    std::vector<double> variance(m.image.texel_count(), 0.0);
    for (size_t t = 0; t < m.image.texel_count(); ++t) {
      for (int k = 0; k < 16; ++k) m.image.add(t, Rgb{1.0 + rng.uniform()});
      colour[t] = m.image.mean(t);
      variance[t] = m.image.valid(t) ? std::pow(m.image.relative_error(t) * luminance(colour[t]), 2) : 0.0;
    }
    time.texels += m.image.texel_count();
    Clock::time_point t0 = Clock::now();
    const TexelGuides guides = texel_guides(m, box);
    time.guides += seconds_since(t0);
    t0 = Clock::now();
    denoise(colour, variance, guides, options);
    time.filter += seconds_since(t0);
    t0 = Clock::now();
    ChartIds charts(box);
    const LightmapResults results = collect_results(m, ResultChannels{false, false, false, true}, {&box, nullptr, &charts});
    denoised_output(results, options, 4, "lin_rec709");
    time.output += seconds_since(t0);
  }
  return time;
}

}  // namespace
}  // namespace kiln::lightmap

// Comma-separated numbers.
std::vector<double> numbers(const char* text) {
  std::vector<double> out;
  for (const char* p = text; *p;) {
    char* end = nullptr;
    out.push_back(std::strtod(p, &end));
    if (end == p) break;
    p = *end == ',' ? end + 1 : end;
  }
  return out;
}

int main(int argc, char** argv) {
  using namespace kiln;
  using namespace kiln::lightmap;
  int resolution = 64, filter_resolution = 1024;
  uint64_t reference_samples = 4096;
  std::string table_out, command = "denoise_bench";
  std::vector<double> sigma_l{DenoiseOptions{}.sigma_luminance}, sigma_n{DenoiseOptions{}.sigma_normal},
      sigma_x{DenoiseOptions{}.sigma_position}, levels{static_cast<double>(DenoiseOptions{}.levels)};
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&](const char* key) { return a.rfind(key, 0) == 0 ? argv[i] + std::strlen(key) : nullptr; };
    if (const char* v = value("--table_out=")) {
      table_out = v;
      continue;
    }
    command += " " + a;
    if (const char* v = value("--resolution=")) {
      resolution = std::atoi(v);
    } else if (const char* v = value("--filter_resolution=")) {
      filter_resolution = std::atoi(v);
    } else if (const char* v = value("--reference=")) {
      reference_samples = std::strtoull(v, nullptr, 10);
    } else if (const char* v = value("--sigma_luminance=")) {
      sigma_l = numbers(v);
    } else if (const char* v = value("--sigma_normal=")) {
      sigma_n = numbers(v);
    } else if (const char* v = value("--sigma_position=")) {
      sigma_x = numbers(v);
    } else if (const char* v = value("--levels=")) {
      levels = numbers(v);
    } else {
      std::fprintf(stderr,
                   "usage: denoise_bench [--table_out=FILE] [--resolution=N] [--reference=S] [--filter_resolution=N] "
                   "[--sigma_luminance=X,...] [--sigma_normal=X,...] [--sigma_position=X,...] [--levels=N,...]\n");
      return 2;
    }
  }
  const scene::Scene box = test::cornell_box();
  auto input = [&](double target, uint64_t seed, const DenoiseOptions& o) {
    LightmapBakeInput in = test::lightmap_input(box, resolution, target);
    in.padding = 4;
    in.seed = seed;
    in.denoise = true;
    in.denoise_options = o;
    return in;
  };

  std::fprintf(stderr, "reference: %llu estimates per texel at %d^2...\n",
               static_cast<unsigned long long>(reference_samples), resolution);
  LightmapBakeInput ref_in = input(1e-4, 987654321, {});
  ref_in.min_samples = ref_in.max_samples = reference_samples;
  ref_in.denoise = false;
  const LightmapBakeResult ref_bake = bake_lightmaps(ref_in);
  const Reference ref{luminances(ref_bake, "_irradiance.exr", false), luminances(ref_bake, "_irradiance.exr", true),
                      ref_bake.error_estimate};

  std::string table;
  auto line = [&](const std::string& s) { table += s + "\n"; };
  line("Cornell box (tests/support/test_scenes.h, 8 lightmaps) at " + std::to_string(resolution) +
       "^2 per lightmap, padding 4; reference: " + std::to_string(reference_samples) +
       " estimates per texel (estimated error " + fmt("%.4f", ref.error) + ", " + fmt("%.0f s", ref_bake.seconds) +
       ").");
  auto removed = [&](double e) { return std::sqrt(std::max(0.0, e * e - ref.error * ref.error)); };
  DenoiseOptions first;
  bool first_set = false;
  for (double l : levels) {
    for (double sl : sigma_l) {
      for (double sn : sigma_n) {
        for (double sx : sigma_x) {
          DenoiseOptions o;
          o.levels = static_cast<int>(l);
          o.sigma_luminance = sl;
          o.sigma_normal = sn;
          o.sigma_position = sx;
          if (!first_set) {
            first = o;
            first_set = true;
          }
          std::fprintf(stderr, "%s\n", describe(o).c_str());
          std::vector<Run> runs;
          for (double target : {0.2, 0.1, 0.05, 0.025}) {
            runs.push_back(measure(fmt("target %g", target), input(target, 1, o), ref));
          }
          // error² × time of the raw bakes, fitted as the mean of log(e² t): Monte Carlo's constant.
          double log_c = 0;
          for (const Run& r : runs) {
            const double e = std::max(1e-6, removed(r.raw_interior));
            log_c += std::log(e * e * (r.wall - r.denoise)) / static_cast<double>(runs.size());
          }
          line("");
          line("Filter: " + describe(o) + ".");
          line("");
          line(
              "| bake | wall s | CPU s | denoise s | raw, all | raw, interior | (ref removed) | denoised, all | "
              "denoised, interior | (ref removed) | denoised vs raw | raw time for that error | time ratio |");
          line("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |");
          for (const Run& r : runs) {
            const double e = removed(r.den_interior), raw_time = std::exp(log_c) / (e * e);
            line("| " + r.label + " | " + fmt("%.2f", r.wall) + " | " + fmt("%.2f", r.cpu) + " | " +
                 fmt("%.3f", r.denoise) + " | " + fmt("%.4f", r.raw_all) + " | " + fmt("%.4f", r.raw_interior) + " | " +
                 fmt("%.4f", removed(r.raw_interior)) + " | " + fmt("%.4f", r.den_all) + " | " +
                 fmt("%.4f", r.den_interior) + " | " + fmt("%.4f", e) + " | " + fmt("%.4f", r.den_vs_raw) + " | " +
                 fmt("%.1f", raw_time) + " | " + fmt("%.2f", raw_time / r.wall) + " |");
          }
        }
      }
    }
  }
  if (filter_resolution > 0) {
    std::fprintf(stderr, "the filter at %d^2...\n", filter_resolution);
    const FilterTime t = filter_seconds(box, filter_resolution, first);
    line("");
    line("The box's 8 lightmaps at " + std::to_string(filter_resolution) + "^2 (" + std::to_string(t.texels) +
         " texels): guides " + fmt("%.2f s", t.guides) + ", filter " + fmt("%.2f s", t.filter) +
         ", the whole denoised output " + fmt("%.2f s", t.output) + " (guides, filter, dilation, EXR encoding), wall.");
  }
  line("");
  line("Command: " + command + " (" + std::to_string(tbb::this_task_arena::max_concurrency()) + " TBB threads)");
  std::fputs(table.c_str(), stdout);
  return kiln::bench::write_table_file(table, table_out);
}
