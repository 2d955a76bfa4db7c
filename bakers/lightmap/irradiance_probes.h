// Irradiance volumes (light probes, issue 20 part 2): at each probe the order-2 SH of incoming radiance (9 RGB
// coefficients, integrator.h's estimate_probe: the lightmaps' transport, lights, environment and media), a validity
// (a probe whose sampled directions see more than a tenth back faces is inside geometry, as a leaking texel is) and a
// standard error. Probes are sampled in rounds (probe_volume.h stops each at its target error): a probe's estimates
// are dealt to kReplicas replicas, whose spread gives the standard error of its DC term's luminance.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "bakers/lightmap/integrator.h"
#include "bakers/lightmap/path_sampler.h"

namespace kiln::lightmap {

using ProbeSh = std::array<Rgb, 9>;

// One probe's running sums, per replica.
struct ProbeSums {
  std::array<ProbeSh, kReplicas> sums{};
  std::array<uint32_t, kReplicas> counts{};
  uint64_t taken = 0, back_faces = 0, rays = 0, dropped = 0;
};

// Adds estimates [from, to) of the probe at p (its index seeds its random numbers): the same estimates whatever the
// rounds that ask for them.
void sample_probe(const TransportContext& ctx, const Vec3& p, size_t index, uint64_t seed, uint64_t from, uint64_t to,
                  ProbeSums& sums);

inline constexpr double kProbeBackFaceTolerance = 0.1;  // the share of back-face hits above which a probe is invalid

struct ProbeSummary {
  ProbeSh sh{};             // the mean over every estimate; 0 when invalid
  double dc_luminance = 0;  // the luminance of the mean DC coefficient
  double error = 0;         // the standard error of dc_luminance, from the replicas' spread
  bool valid = true;
};
ProbeSummary summarize_probe(const ProbeSums& sums);

// Probe (i, j, k) of a regular grid stands at origin + spacing·(i, j, k).
struct ProbeGrid {
  Vec3 origin;
  double spacing = 1;
  int nx = 0, ny = 0, nz = 0;
  size_t count() const { return static_cast<size_t>(nx) * ny * nz; }
  Vec3 position(int i, int j, int k) const { return origin + Vec3{double(i), double(j), double(k)} * spacing; }
};

// Every probe of `grid` (x fastest) at `samples` estimates each: the baker's core, for tests.
std::vector<ProbeSummary> bake_probe_grid(const TransportContext& ctx, const ProbeGrid& grid, uint64_t samples,
                                          uint64_t seed = 1);

}  // namespace kiln::lightmap
