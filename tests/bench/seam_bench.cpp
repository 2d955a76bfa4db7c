// The seam stitcher on every page of the generated level (tests/bench/level_scene.h) packed as level_bench packs it:
// per page, the seams found, the system's unknowns and components, how many were factored, the stitcher's peak bytes
// (SeamStitcher::peak_bytes) per page texel and per unknown, the factors' bytes (capped at F per texel), and the
// seconds to build and solve, for an image whose lookups disagree everywhere (noise), so that every page builds its
// system as a sampled page does.
//
//   seam_bench [--texel-density=D] [--page-size=N] [--factor-budget=B] [--factor-bytes-per-texel=F]
//
// Every texel counts as valid: the system's size does not depend on validity, only its weights do.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "bakers/lightmap/atlas_pack.h"
#include "bakers/lightmap/seams.h"
#include "tests/bench/packed_level.h"

namespace kiln::bench {
namespace {

struct Args {
  double texel_density = 10, factor_budget = lightmap::StitchOptions{}.factor_budget;
  double factor_bytes_per_texel = lightmap::StitchOptions{}.factor_bytes_per_texel;
  int page_size = 2048;
};

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string s = argv[i];
    if (s.rfind("--texel-density=", 0) == 0) {
      a.texel_density = std::atof(s.c_str() + 16);
    } else if (s.rfind("--page-size=", 0) == 0) {
      a.page_size = std::atoi(s.c_str() + 12);
    } else if (s.rfind("--factor-bytes-per-texel=", 0) == 0) {
      a.factor_bytes_per_texel = std::atof(s.c_str() + 25);
    } else if (s.rfind("--factor-budget=", 0) == 0) {
      a.factor_budget = std::atof(s.c_str() + 16);
    } else {
      std::fprintf(stderr, "seam_bench: unknown argument '%s' (see the top of tests/bench/seam_bench.cpp)\n",
                   s.c_str());
      std::exit(2);
    }
  }
  return a;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace
}  // namespace kiln::bench

int main(int argc, char** argv) {
  using namespace kiln;
  const bench::Args a = bench::parse(argc, argv);
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  lightmap::AtlasPack pack;
  const scene::CheckedScene checked = bench::packed_level(a.texel_density, a.page_size, pack);
  lightmap::StitchOptions options;
  options.factor_budget = a.factor_budget;
  options.factor_bytes_per_texel = a.factor_bytes_per_texel;
  std::printf(
      "level at %g texels/m, %zu pages; factor budget %g values per matrix entry, factors at most %g bytes per "
      "texel\n",
      a.texel_density, pack.pages.size(), a.factor_budget, a.factor_bytes_per_texel);
  std::printf("%-6s %6s %9s %10s %10s %9s %10s %11s %9s %9s %8s %8s %6s %8s\n", "page", "side", "seams", "unknowns",
              "components", "factored", "factor MB", "peak MB", "B/texel", "B/unknown", "build s", "solve s", "held",
              "lookup B/texel");
  size_t worst = 0;
  double worst_per_texel = 0;
  for (size_t p = 0; p < pack.pages.size(); ++p) {
    const int side = pack.pages[p].size;
    const size_t texels = static_cast<size_t>(side) * side;
    const auto t0 = std::chrono::steady_clock::now();
    const lightmap::SeamSearch found =
        lightmap::find_seams(checked, lightmap::atlas_page_name(static_cast<int>(p)), side, side);
    lightmap::SeamStitcher stitcher(found.seams, side, side, std::vector<uint8_t>(texels, 1), options);
    const double build = bench::seconds_since(t0);
    image::FloatImage image;
    image.width = image.height = side;
    image.channels = 3;
    image.pixels.resize(texels * 3);
    std::mt19937 rng(static_cast<unsigned>(p));
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (float& v : image.pixels) v = u(rng);
    const auto t1 = std::chrono::steady_clock::now();
    const lightmap::StitchStats s = stitcher.stitch(image);
    const double solve = bench::seconds_since(t1);
    const double peak = static_cast<double>(stitcher.peak_bytes());
    std::printf("%-6zu %6d %9zu %10zu %10zu %9zu %10.1f %11.1f %9.1f %9.1f %8.2f %8.2f %6zu %8.2f (%zu over)\n", p,
                side, found.seams.size(), stitcher.unknowns(), s.components, s.factored,
                static_cast<double>(stitcher.factor_bytes()) / 1e6, peak / 1e6, peak / static_cast<double>(texels),
                peak / static_cast<double>(std::max<size_t>(stitcher.unknowns(), 1)), build, solve, s.held_at_zero,
                static_cast<double>(stitcher.samples() * lightmap::kLookupPointBytes) / static_cast<double>(texels),
                stitcher.seams_over_budget());
    worst = std::max(worst, stitcher.peak_bytes());
    worst_per_texel = std::max(worst_per_texel, peak / static_cast<double>(texels));
  }
  std::printf("largest peak %.1f MB, most bytes per page texel %.1f\n", static_cast<double>(worst) / 1e6,
              worst_per_texel);
  return 0;
}
