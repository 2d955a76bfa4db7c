// What the environment bake's specular chain costs and how accurate it is, against sample budgets: a generated
// 2048 × 1024 sky (a gradient with bands of structure and a ground, plus a small sun 2·10^4 times the sky) is
// resampled to a 256² cube, split into sky and sun (sun.h), and the full chain (7 levels, 256² … 4², GGX) is
// prefiltered at 16, 64, 256 and 1024 samples per texel, then with samples chosen from the default target error.
//
//   environment_bench [--table_out=FILE] [--quick] [--lod_bias=B[,B...]] [--image=FILE.exr] [--seed=S]
//
// Plain timing with a custom main (wall-clock, steady_clock, both cores through TBB; one run each): the unit of work
// is a whole chain, seconds long, so Google Benchmark's repetition machinery adds nothing. Each chain's time
// includes its honest error check (a brute-force convolution at 96 texels per level, prefilter.h), a fixed cost of a
// few seconds that dominates the small budgets. --quick: a 64² cube (5 levels) from the same image, ~1 minute.
//
// The reference: brute force of the whole map (sky + sun as one cube, every one of its 6·256² texels summed with
// exact solid angles and the same normalised lobe, prefilter.h) at a stratified set of 6 × 6 × 6 = 216 texels per
// level (an offset grid, distinct from the bake's own checked subset). A full-resolution brute-force chain would cost
// ~10^11 lobe evaluations; 216 texels per level estimate the RMS to ~±10 % and take ~20 s. The brute force treats
// the map as piecewise constant at texel centres, the sampler reads it bilinearly: they differ slightly for the
// narrowest lobe (level 1, α = 1/36, ~7 source texels wide), which puts a floor of ~1e-3 under level 1's error.
// Errors are relative_rms_error (prefilter.h); "overall" is the RMS over all levels' checked texels. Each level's cell
// also gives its wall seconds (the choice of N and the bake's own check included). --lod_bias: the rows for each
// filtered-importance-sampling bias given (PrefilterOptions::lod_bias; default 1), in the same process. --image: the
// sky is that equirectangular image (decoded and resampled as the bake does) instead of the generated one, e.g.
// `kiln-sky --width 2048`, the whole-job benchmark's case; --seed: the chain's seed (0; the bake's default is 1).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <tbb/parallel_for.h>

#include "bakers/envmap/cubemap.h"
#include "bakers/envmap/env_input.h"
#include "bakers/envmap/lobe.h"
#include "bakers/envmap/prefilter.h"
#include "bakers/envmap/sun.h"
#include "bakers/math/constants.h"
#include "tests/bench/process_cpu.h"
#include "tests/bench/table_file.h"

namespace kiln::envmap {
namespace {

const Vec3 kSunDir = normalize(Vec3{0.4, 0.55, -0.7});
constexpr double kSunRadius = 0.0047;  // radians (0.27°, the real sun's angular radius)
constexpr double kSunContrastFactor = 2e4;

Rgb sky_radiance(const Vec3& d) {
  if (d.y < 0) return Rgb{0.12, 0.10, 0.08} * (1.0 + 0.3 * std::sin(9.0 * d.x) * std::sin(7.0 * d.z));  // ground
  const double h = d.y;
  Rgb sky = Rgb{0.35, 0.55, 0.95} * (0.6 + 0.4 * h) + Rgb{0.6, 0.55, 0.5} * std::pow(1.0 - h, 4.0);
  // Cloud-like bands and a glow around the sun: structure at several scales.
  const double bands = 0.5 + 0.5 * std::sin(13.0 * d.x + 5.0 * d.z) * std::sin(11.0 * h);
  sky = sky * (0.7 + 0.6 * bands * bands);
  const double c = dot(d, kSunDir);
  sky += Rgb{1.0, 0.9, 0.7} * (2.0 * std::exp((c - 1.0) * 40.0));
  if (c > std::cos(kSunRadius)) sky = Rgb{1.0, 0.95, 0.85} * (kSunContrastFactor * 1.0);
  return sky;
}

RgbImage make_equirect(int w, int h) {
  RgbImage img(w, h);
  tbb::parallel_for(0, h, [&](int y) {
    for (int x = 0; x < w; ++x) img.at(x, y) = sky_radiance(equirect_uv_to_direction((x + 0.5) / w, (y + 0.5) / h));
  });
  return img;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

struct Probe {
  int face, x, y;
  Rgb reference;
};

std::vector<std::vector<Probe>> references(const Cubemap& full, int out_size, int levels) {
  std::vector<double> omega(static_cast<size_t>(full.size()) * full.size());
  const int m = full.size();
  for (int y = 0; y < m; ++y)
    for (int x = 0; x < m; ++x) omega[static_cast<size_t>(y) * m + x] = texel_solid_angle(x, y, m);
  std::vector<std::vector<Probe>> out(levels);
  for (int k = 1; k < levels; ++k) {
    const int size = std::max(1, out_size >> k);
    const int grid = std::min(size, 6);
    for (int f = 0; f < kFaceCount; ++f)
      for (int j = 0; j < grid; ++j)
        for (int i = 0; i < grid; ++i)
          out[k].push_back(
              {f, static_cast<int>((i + 0.37) * size / grid), static_cast<int>((j + 0.61) * size / grid), {}});
    const SplitSumLobe lobe(brdf::Distribution::ggx, lobe_alpha(prefilter_level_roughness(k, levels)));
    tbb::parallel_for(size_t{0}, out[k].size(), [&](size_t p) {
      Probe& pr = out[k][p];
      const Vec3 n = texel_direction(pr.face, pr.x, pr.y, size);
      Rgb sum;
      double w = 0;
      for (int f = 0; f < kFaceCount; ++f)
        for (int y = 0; y < m; ++y)
          for (int x = 0; x < m; ++x) {
            const double wt = lobe.weight(n, texel_direction(f, x, y, m)) * omega[static_cast<size_t>(y) * m + x];
            if (wt == 0.0) continue;
            sum += full.at(f, x, y) * wt;
            w += wt;
          }
      pr.reference = sum / w;
    });
  }
  return out;
}

// Per level and overall relative RMS error at the probes (relative_rms_error on 1-texel-wide "cubes" would lose the
// level's floor; the same formula is applied here to the probe set).
std::vector<double> errors(const std::vector<PrefilteredLevel>& chain, const std::vector<std::vector<Probe>>& probes,
                           double* overall) {
  std::vector<double> e(chain.size(), 0.0);
  double acc = 0;
  int count = 0;
  for (size_t k = 1; k < chain.size(); ++k) {
    double mean_sq = 0;
    for (const Probe& p : probes[k]) {
      const Rgb& r = p.reference;
      mean_sq += (r.r * r.r + r.g * r.g + r.b * r.b) / probes[k].size();
    }
    const double floor_sq = kRelativeErrorFloor * kRelativeErrorFloor * mean_sq;
    double lvl = 0;
    for (const Probe& p : probes[k]) {
      const Rgb d = chain[k].cube.at(p.face, p.x, p.y) - p.reference, r = p.reference;
      const double t = (d.r * d.r + d.g * d.g + d.b * d.b) / std::max(r.r * r.r + r.g * r.g + r.b * r.b, floor_sq);
      lvl += t;
      acc += t;
      ++count;
    }
    e[k] = std::sqrt(lvl / probes[k].size());
  }
  *overall = std::sqrt(acc / count);
  return e;
}

}  // namespace
}  // namespace kiln::envmap

// "1,0.5" → {1, 0.5}; empty on a malformed list.
std::vector<double> parse_list(const char* text) {
  std::vector<double> out;
  for (const char* p = text; *p;) {
    char* end = nullptr;
    const double v = std::strtod(p, &end);
    if (end == p || !std::isfinite(v)) return {};
    out.push_back(v);
    p = *end == ',' ? end + 1 : end;
    if (*end && *end != ',') return {};
  }
  return out;
}

int main(int argc, char** argv) {
  using namespace kiln::envmap;
  std::string table_out, command = argv[0];
  bool quick = false, usage = false;
  std::vector<double> lod_biases{kDefaultLodBias};
  std::string image_path;
  uint64_t seed = 0;
  for (int i = 1; i < argc; ++i) {
    command += std::string(" ") + argv[i];
    if (std::strncmp(argv[i], "--table_out=", 12) == 0)
      table_out = argv[i] + 12;
    else if (std::strcmp(argv[i], "--quick") == 0)
      quick = true;
    else if (std::strncmp(argv[i], "--lod_bias=", 11) == 0)
      usage |= (lod_biases = parse_list(argv[i] + 11)).empty();
    else if (std::strncmp(argv[i], "--image=", 8) == 0)
      image_path = argv[i] + 8;
    else if (std::strncmp(argv[i], "--seed=", 7) == 0)
      seed = std::strtoull(argv[i] + 7, nullptr, 10);
    else
      usage = true;
  }
  if (usage) {
    std::fprintf(stderr, "usage: %s [--table_out=FILE] [--quick] [--lod_bias=B[,B...]] [--image=FILE.exr] [--seed=S]\n",
                 argv[0]);
    return 1;
  }
  const int size = quick ? 64 : 256, levels = quick ? 5 : 7;
  auto t0 = std::chrono::steady_clock::now();
  Cubemap full;
  if (image_path.empty()) {
    full = resample_equirect_to_cube(make_equirect(2048, 1024), size);
  } else {
    std::ifstream f(image_path, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    if (bytes.empty()) {
      std::fprintf(stderr, "cannot read %s\n", image_path.c_str());
      return 1;
    }
    full = environment_to_cube(decode_environment(bytes), size);
  }
  const double t_resample = seconds_since(t0);
  t0 = std::chrono::steady_clock::now();
  const SunSplit split = split_sun(full);
  const double t_split = seconds_since(t0);
  std::printf("source: %s -> %d^2 cube in %.2f s; sun split in %.3f s: %s\n",
              image_path.empty() ? "generated 2048x1024" : image_path.c_str(), size, t_resample, t_split,
              split.reason.c_str());
  std::printf("reference: brute force at 216 texels per level...\n");
  t0 = std::chrono::steady_clock::now();
  const auto probes = references(full, size, levels);
  std::printf("  %.1f s\n", seconds_since(t0));

  std::string t = "| samples/texel | chain time (s) | chain CPU (s) | overall error |";
  for (int k = 1; k < levels; ++k) t += " L" + std::to_string(k) + " (" + std::to_string(size >> k) + "²) |";
  t += "\n|---|---|---|---|";
  for (int k = 1; k < levels; ++k) t += "---|";
  t += "\n";
  // One chain: its wall and CPU seconds, the overall error, and per level the error, the bake's own estimate, N (when
  // chosen from the target) and the level's seconds.
  auto row = [&](const std::string& label, const Cubemap& sky, const std::vector<SunTexel>& sun,
                 const PrefilterOptions& o) {
    const auto s0 = std::chrono::steady_clock::now();
    const double c0 = kiln::bench::process_cpu_seconds();
    const std::vector<PrefilteredLevel> chain = prefilter_specular(sky, sun, size, o);
    const double cpu = kiln::bench::process_cpu_seconds() - c0, secs = seconds_since(s0);
    double overall = 0;
    const auto e = errors(chain, probes, &overall);
    char buf[160];
    std::snprintf(buf, sizeof buf, "| %s | %.2f | %.2f | %.2e |", label.c_str(), secs, cpu, overall);
    std::string line = buf;
    for (int k = 1; k < levels; ++k) {
      std::snprintf(buf, sizeof buf, " %.2e (est %.1e%s, %.2f s) |", e[k], chain[k].error_estimate,
                    o.samples == 0 ? (", N=" + std::to_string(chain[k].samples)).c_str() : "", chain[k].seconds);
      line += buf;
    }
    std::printf("%s\n", line.c_str());
    std::fflush(stdout);
    t += line + "\n";
  };
  const SunSplit no_sun = split_sun(full, SunMode::forced_off);
  for (double bias : lod_biases) {
    char suffix[48] = "";
    if (lod_biases.size() > 1) std::snprintf(suffix, sizeof suffix, ", lod bias %g", bias);
    for (int n : {16, 64, 256, 1024}) {
      PrefilterOptions o{levels, n};
      o.lod_bias = bias;
      o.seed = seed;
      row(std::to_string(n) + suffix, split.sky, split.sun, o);
    }
    PrefilterOptions o{levels, 0};
    o.target_error = 0.01;
    o.lod_bias = bias;
    o.seed = seed;
    row(std::string("auto, target 0.01") + suffix, split.sky, split.sun, o);
    PrefilterOptions off{levels, 256};
    off.lod_bias = bias;
    off.seed = seed;
    row(std::string("256, sun_light forced off") + suffix, no_sun.sky, {}, off);
    // The sun in the sampled map at the default target: what a map with small bright sources that are not split off
    // as a sun costs (filtered importance sampling's bias trades blur against such sources' noise).
    PrefilterOptions off_auto = o;
    row(std::string("auto, target 0.01, sun_light forced off") + suffix, no_sun.sky, {}, off_auto);
  }
  t += "\nErrors: relative RMS against brute force at 216 texels per level (est = the bake's own error_estimate). "
       "Command: `" +
       command + "`\n";
  std::printf("\n%s", t.c_str());
  return kiln::bench::write_table_file(t, table_out);
}
