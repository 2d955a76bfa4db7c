// What participating media cost a lightmap bake, and what the planner's attenuation-only mode saves: the bundled
// Cornell box (tests/support/test_scenes.h, 8 lightmaps) at 16² per lightmap, lit by its ceiling patch and a low sun
// through its open side (client/examples/scenes/cornell_box_fog.textproto's), baked
//   - without media,
//   - with that example's fog (sigma_a 0.02, sigma_s 0.16–0.2 per metre, g 0.6) in full (free flights, scattering),
//   - with the same fog as attenuation only (media_scattering forced off: transmittance, no in-scattering),
//   - with a cloud of smoke from a VDB grid instead (fog_box.h's example_smoke: delta and ratio tracking against its
//     majorant grid, in full),
// each at fixed budgets of N estimates per texel. The error is the RMS over every valid texel of every lightmap of
// the luminance difference from a reference of the same configuration (512 estimates per texel), over that
// lightmap's mean luminance (the lightmap error metric); "bias" compares attenuation only's reference with the
// full one's. CPU seconds are the process's.
//
//   media_lightmap_bench [--table_out=FILE]
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <string>
#include <vector>

#include "bakers/lightmap/lightmap_bake.h"
#include "tests/bench/fog_box.h"
#include "tests/bench/table_file.h"
#include "tests/support/test_scenes.h"

namespace kiln::lightmap {
namespace {

enum class Fog { none, full, attenuation, smoke };

LightmapBakeInput box_input(Fog fog, uint64_t samples) {
  LightmapBakeInput in = test::lightmap_input(bench::cornell_box_with_sun(), 16, 1e-4);
  in.min_samples = in.max_samples = samples;
  in.seed = 11;
  if (fog == Fog::none) return in;
  in.media.push_back(fog == Fog::smoke ? bench::example_smoke() : bench::example_fog());
  if (fog == Fog::attenuation) in.force_effects["media_scattering"] = false;
  return in;
}

double luminance(const image::FloatImage& E, int x, int y) {
  return 0.2126 * E.at(x, y, 0) + 0.7152 * E.at(x, y, 1) + 0.0722 * E.at(x, y, 2);
}

// RMS over the valid texels of every lightmap of (a − b) / b's mean luminance in that lightmap.
double rms_error(const LightmapBakeResult& a, const LightmapBakeResult& b) {
  double sum = 0;
  size_t n = 0;
  for (const bake::BakeOutput& o : b.outputs) {
    const std::string suffix = "_irradiance.exr";
    if (o.name.size() <= suffix.size() || o.name.compare(o.name.size() - suffix.size(), suffix.size(), suffix) != 0)
      continue;
    const std::string map = o.name.substr(0, o.name.size() - suffix.size());
    const image::FloatImage Eb = test::exr_output(b, o.name), Ea = test::exr_output(a, o.name);
    const image::FloatImage valid = test::exr_output(b, map + "_validity.exr");
    double mean = 0;
    size_t texels = 0;
    for (int y = 0; y < Eb.height; ++y)
      for (int x = 0; x < Eb.width; ++x)
        if (valid.at(x, y, 0) > 0.5) mean += luminance(Eb, x, y), ++texels;
    if (texels == 0 || !(mean > 0)) continue;
    mean /= texels;
    for (int y = 0; y < Eb.height; ++y)
      for (int x = 0; x < Eb.width; ++x) {
        if (valid.at(x, y, 0) <= 0.5) continue;
        const double d = (luminance(Ea, x, y) - luminance(Eb, x, y)) / mean;
        sum += d * d;
        ++n;
      }
  }
  return n ? std::sqrt(sum / n) : 0.0;
}

struct Timed {
  LightmapBakeResult result;
  double cpu_seconds = 0;
};

Timed bake(Fog fog, uint64_t samples) {
  const std::clock_t c0 = std::clock();
  Timed t{bake_lightmaps(box_input(fog, samples))};
  t.cpu_seconds = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
  return t;
}

const char* name(Fog fog) {
  switch (fog) {
    case Fog::none:
      return "no media";
    case Fog::full:
      return "fog, full";
    case Fog::attenuation:
      return "fog, attenuation";
    case Fog::smoke:
      return "VDB smoke, full";
  }
  return "";
}

std::string table() {
  std::string out = "| configuration | N per texel | CPU (s) | rays | error vs its reference |\n";
  out += "| --- | ---: | ---: | ---: | ---: |\n";
  std::vector<Timed> refs;
  for (Fog fog : {Fog::none, Fog::full, Fog::attenuation, Fog::smoke}) {
    refs.push_back(bake(fog, 512));
    for (uint64_t n : {16, 64}) {
      const Timed t = bake(fog, n);
      char line[256];
      std::snprintf(line, sizeof line, "| %s | %llu | %.2f | %llu | %.4f |\n", name(fog),
                    static_cast<unsigned long long>(n), t.cpu_seconds, static_cast<unsigned long long>(t.result.rays),
                    rms_error(t.result, refs.back().result));
      out += line;
    }
    char line[256];
    std::snprintf(line, sizeof line, "| %s (reference) | 512 | %.2f | %llu | |\n", name(fog), refs.back().cpu_seconds,
                  static_cast<unsigned long long>(refs.back().result.rays));
    out += line;
  }
  char line[256];
  std::snprintf(line, sizeof line,
                "\nAttenuation only against full at 512 per texel (bias plus both references' noise): %.4f; fog "
                "against no media: %.4f; smoke against no media: %.4f\n",
                rms_error(refs[2].result, refs[1].result), rms_error(refs[0].result, refs[1].result),
                rms_error(refs[0].result, refs[3].result));
  return out + line;
}

}  // namespace
}  // namespace kiln::lightmap

int main(int argc, char** argv) {
  return kiln::bench::table_bench_main(argc, argv, "media_lightmap_bench", kiln::lightmap::table);
}
