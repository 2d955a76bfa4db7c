// What delta and ratio tracking cost for what error (bakers/volume/tracking.h): transmittance along 64 fixed rays
// through a heterogeneous VDB grid (tests/volume/media_test_util.h's lumpy ball, sigma_a = (0.5, 1, 2) and sigma_s =
// (1, 1, 1) per unit density, 3 m⁻¹ × density up to ~6: optical depths 0–4 along the rays), each estimator averaged
// over N estimates per ray, against quadrature of exp(−∫ sigma_t) (2·10⁵ midpoint steps, error ~1e-7).
//
//   media_bench [--table_out=FILE] [--scale=S]
//
// --scale multiplies the coefficients (denser media: delta tracking's binary estimates lose more against ratio
// tracking's fractional ones). The error is the RMS over rays and channels of mean − reference; the time is the
// process's CPU time for all rays' N estimates, the fastest of 3 runs; "error² × time" is the efficiency figure of
// merit (constant in N for an unbiased estimator: lower is better).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>
#include <vector>

#include "bakers/volume/grid_medium.h"
#include "bakers/volume/tracking.h"
#include "tests/bench/table_file.h"
#include "tests/volume/media_test_util.h"

namespace kiln::volume {
namespace {

using Estimator = Rgb (*)(const Medium&, const scene::Ray&, double, Pcg32&);

struct Row {
  double rms = 0, seconds = 0;
};

std::vector<scene::Ray> fixed_rays(int count) {
  Pcg32 rng(2024);
  std::vector<scene::Ray> rays;
  for (int i = 0; i < count; ++i) {
    const Vec3 from{rng.uniform() - 0.5, rng.uniform(), rng.uniform()}, to{1.5, rng.uniform(), rng.uniform()};
    rays.push_back({from, to - from});
  }
  return rays;
}

double cpu_seconds() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }

// One run: every ray's mean of n estimates against its reference.
Row run(const Medium& m, const std::vector<scene::Ray>& rays, const std::vector<Rgb>& refs, Estimator e, int n) {
  Pcg32 rng(7, static_cast<uint64_t>(n));
  double sum2 = 0;
  const double start = cpu_seconds();
  for (size_t r = 0; r < rays.size(); ++r) {
    Rgb mean;
    for (int i = 0; i < n; ++i) mean += e(m, rays[r], 1.0, rng);
    const Rgb d = mean / n - refs[r];
    sum2 += d.r * d.r + d.g * d.g + d.b * d.b;
  }
  return {std::sqrt(sum2 / (3.0 * rays.size())), cpu_seconds() - start};
}

std::string table(const Medium& m, const std::vector<scene::Ray>& rays, const std::vector<Rgb>& refs) {
  std::string out = "| estimator | N per ray | RMS error | CPU ms (64 rays) | error² × time (s) |\n";
  out += "| --- | ---: | ---: | ---: | ---: |\n";
  const std::pair<const char*, Estimator> estimators[] = {{"ratio tracking", &ratio_tracking_transmittance},
                                                          {"delta tracking", &delta_tracking_transmittance}};
  for (const auto& [name, e] : estimators)
    for (int n : {4, 16, 64, 256, 1024}) {
      Row best = run(m, rays, refs, e, n);
      for (int rep = 0; rep < 2; ++rep) best.seconds = std::min(best.seconds, run(m, rays, refs, e, n).seconds);
      char line[200];
      std::snprintf(line, sizeof line, "| %s | %d | %.2e | %.1f | %.2e |\n", name, n, best.rms, best.seconds * 1e3,
                    best.rms * best.rms * best.seconds);
      out += line;
    }
  return out;
}

}  // namespace
}  // namespace kiln::volume

int main(int argc, char** argv) {
  using namespace kiln::volume;
  std::string table_out;
  double scale = 1;
  for (int i = 1; i < argc; ++i) {
    if (std::strncmp(argv[i], "--table_out=", 12) == 0) {
      table_out = argv[i] + 12;
    } else if (std::strncmp(argv[i], "--scale=", 8) == 0) {
      scale = std::atof(argv[i] + 8);
    } else {
      std::fprintf(stderr, "usage: media_bench [--table_out=FILE] [--scale=S]\n");
      return 2;
    }
  }
  const GridMedium ball({test::lumpy_ball_grid(), {}, {}, kiln::Rgb(0.5, 1, 2) * scale, kiln::Rgb(1) * scale, {}, 0});
  const std::vector<kiln::scene::Ray> rays = fixed_rays(64);
  std::vector<kiln::Rgb> refs;
  for (const auto& r : rays) refs.push_back(test::quadrature_transmittance(ball, r, 1.0, 200000));
  const std::string t = table(ball, rays, refs);
  std::fputs(t.c_str(), stdout);
  return kiln::bench::write_table_file(t, table_out);
}
