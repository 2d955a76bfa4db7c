// The probe baking rate: the bundled Cornell box (tests/support/test_scenes.h) under its ceiling patch and a low sun
// through its open side (client/examples/scenes/cornell_box_fog.textproto's), without and with that example's fog,
// its light probes baked alone (spacing 0.25, within 0.5 of a surface: 1531 probes) at fixed budgets of N estimates
// per probe, against the baseline of the same process: the box's lightmaps (16² per lightmap) at N estimates per
// texel. Rates are estimates per CPU second (the process's); the ratio says what a probe estimate costs against a
// texel's (a probe traces a sphere of directions through the same transport). The RMS error is report.json's: the
// valid probes' estimated relative errors (lightmap metric).
//
//   probe_bench [--table_out=FILE]
#include <cstdio>
#include <cstring>
#include <ctime>
#include <string>

#include <nlohmann/json.hpp>

#include "bakers/lightmap/lightmap_bake.h"
#include "tests/bench/fog_box.h"
#include "tests/bench/table_file.h"
#include "tests/support/test_scenes.h"

namespace kiln::lightmap {
namespace {

LightmapBakeInput box_input(bool fog, uint64_t samples, bool probes) {
  LightmapBakeInput in = test::lightmap_input(bench::cornell_box_with_sun(), 16, 1e-4);
  in.min_samples = in.max_samples = samples;
  in.seed = 13;
  if (probes) {
    in.lightmaps = false;
    in.probes.spacing = 0.25;
  }
  if (!fog) return in;
  in.media.push_back(bench::example_fog());
  return in;
}

struct Timed {
  LightmapBakeResult result;
  double cpu_seconds = 0;
  double rate() const { return static_cast<double>(result.samples) / cpu_seconds; }
};

Timed bake(bool fog, uint64_t samples, bool probes) {
  const std::clock_t c0 = std::clock();
  Timed t{bake_lightmaps(box_input(fog, samples, probes))};
  t.cpu_seconds = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
  return t;
}

std::string table() {
  std::string out =
      "| scene | N | probes (valid) | estimates | CPU (s) | estimates/s | texel estimates/s | ratio | RMS error |\n"
      "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n";
  for (bool fog : {false, true}) {
    for (uint64_t n : {16, 64, 256}) {
      const Timed texels = bake(fog, n, false), probes = bake(fog, n, true);
      const nlohmann::json p =
          nlohmann::json::parse(test::find_output(probes.result, "report.json").bytes)["probes"];
      char line[320];
      std::snprintf(line, sizeof line, "| %s | %llu | %zu (%zu) | %llu | %.2f | %.3g | %.3g | %.2f | %.4f |\n",
                    fog ? "box, fog" : "box", static_cast<unsigned long long>(n),
                    p["counts"]["placed"].get<size_t>(), p["counts"]["valid"].get<size_t>(),
                    static_cast<unsigned long long>(probes.result.samples), probes.cpu_seconds, probes.rate(),
                    texels.rate(), probes.rate() / texels.rate(), p["error"]["rms"].get<double>());
      out += line;
    }
  }
  return out;
}

}  // namespace
}  // namespace kiln::lightmap

int main(int argc, char** argv) {
  return kiln::bench::table_bench_main(argc, argv, "probe_bench", kiln::lightmap::table);
}
