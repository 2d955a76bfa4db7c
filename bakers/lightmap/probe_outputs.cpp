#include "bakers/lightmap/probe_outputs.h"

#include <algorithm>
#include <cmath>
#include <map>

#include <nlohmann/json.hpp>

#include "bakers/bake/number_format.h"
#include "bakers/envmap/sh.h"
#include "bakers/image/display_png.h"
#include "bakers/lightmap/lightmap_bake.h"
#include "bakers/volume/probe_vdb.h"

namespace kiln::lightmap {
namespace {

using Json = nlohmann::ordered_json;
using bake::format_number;

std::map<std::string, std::string> file_metadata(const ProbeVolumeResult& r, const std::string& color_space) {
  const ProbePlacement& p = r.placement;
  return {
      {"kiln:baker", kLightmapBakerVersion},
      {"kiln:content", "light probes: order-2 SH of incoming radiance at each active voxel"},
      // The basis part of the environment bake's header: the probes hold radiance, not its irradiance coefficients.
      {"kiln:sh_basis",
       std::string(envmap::kShIrradianceHeader.substr(2, envmap::kShIrradianceHeader.find("; coefficients") - 2))},
      {"kiln:sh_coefficients",
       "grids sh<K>_<r|g|b> hold radiance coefficients L_K = integral of L(w) Y_K(w) dw (not irradiance); "
       "E(n) = sum_K A_l(K) L_K Y_K(n) with A = (pi, 2pi/3, pi/4)"},
      {"kiln:units", "radiance W m^-2 sr^-1 (scene-linear RGB); lengths in scene units"},
      {"kiln:color_space", color_space},
      {"kiln:spacing", format_number(p.spacing)},
      {"kiln:origin", format_number(p.origin.x) + " " + format_number(p.origin.y) + " " + format_number(p.origin.z)},
      {"kiln:transform", "world = origin + spacing * index (the grids' linear transform)"},
      {"kiln:validity", "grid validity: 1 valid, 0 inside geometry (SH 0); absent voxels: no probe"},
      {"kiln:error", "grid error: the probe's relative standard error of its DC luminance, metric " +
                         std::string(to_string(r.sampling.stopping.metric))},
  };
}

std::vector<volume::ProbeGridValues> probe_grids(const ProbeVolumeResult& r) {
  std::vector<volume::ProbeGridValues> grids;
  const size_t n = r.probes.size();
  const char* channels[3] = {"r", "g", "b"};
  for (int k = 0; k < 9; ++k) {
    for (int c = 0; c < 3; ++c) {
      volume::ProbeGridValues g{"sh" + std::to_string(k) + "_" + channels[c], std::vector<float>(n), {}};
      for (size_t p = 0; p < n; ++p) g.values[p] = static_cast<float>(r.probes[p].sh[k][c]);
      g.metadata = {{"kiln:sh_index", std::to_string(k)},
                    {"kiln:sh_band", std::to_string(envmap::sh_band(k))},
                    {"kiln:channel", channels[c]}};
      grids.push_back(std::move(g));
    }
  }
  volume::ProbeGridValues valid{"validity", std::vector<float>(n), {{"kiln:meaning", "1 valid, 0 inside geometry"}}};
  volume::ProbeGridValues error{"error", std::vector<float>(n), {{"kiln:meaning", "relative standard error"}}};
  for (size_t p = 0; p < n; ++p) {
    valid.values[p] = r.probes[p].valid ? 1.0f : 0.0f;
    // A probe whose error is unknown (a black reference) stores the largest float rather than infinity.
    error.values[p] = static_cast<float>(std::min(r.relative_error[p], 3.0e38));
  }
  grids.push_back(std::move(valid));
  grids.push_back(std::move(error));
  return grids;
}

// The layer (lattice y index) holding the most valid probes: the preview shows it from above.
int busiest_layer(const ProbeVolumeResult& r) {
  std::map<int, size_t> count;
  for (size_t p = 0; p < r.probes.size(); ++p) count[r.placement.voxels[p][1]] += r.probes[p].valid;
  int best = 0;
  size_t most = 0;
  for (const auto& [j, c] : count)
    if (c > most) {
      best = j;
      most = c;
    }
  return best;
}

// White Lambertian spheres lit by the probes of one layer, seen from above (+Y toward the viewer, +x right, +z down):
// each pixel's radiance E(n)/π for the sphere's normal there. Absent and invalid probes leave black.
bake::BakeOutput preview(const ProbeVolumeResult& r, const std::string& color_space) {
  const int layer = busiest_layer(r);
  int i0 = 1 << 30, k0 = 1 << 30, i1 = -1, k1 = -1;
  for (const auto& v : r.placement.voxels) {
    if (v[1] != layer) continue;
    i0 = std::min(i0, v[0]), i1 = std::max(i1, v[0]), k0 = std::min(k0, v[2]), k1 = std::max(k1, v[2]);
  }
  const int nx = std::max(1, i1 - i0 + 1), nz = std::max(1, k1 - k0 + 1);
  const int cell = std::clamp(1024 / std::max(nx, nz), 1, 24);  // at most about 1024 pixels a side
  const int w = nx * cell, h = nz * cell;
  std::vector<float> pixels(static_cast<size_t>(w) * h * 3, 0.0f);
  std::vector<double> luma;
  for (size_t p = 0; p < r.probes.size(); ++p) {
    const auto& v = r.placement.voxels[p];
    if (v[1] != layer || !r.probes[p].valid) continue;
    for (int y = 0; y < cell; ++y)
      for (int x = 0; x < cell; ++x) {
        const double u = (x + 0.5) / cell * 2 - 1, t = (y + 0.5) / cell * 2 - 1, rho2 = u * u + t * t;
        // One pixel a probe: its irradiance for +Y. Larger cells: a disc with the sphere's normals.
        if (cell > 2 && rho2 > 1) continue;
        const Vec3 n = cell > 2 ? Vec3{u, std::sqrt(std::max(0.0, 1 - rho2)), t} : Vec3{0, 1, 0};
        const Rgb L = probe_irradiance(r.probes[p].sh, n) / kPi;
        const size_t at = (static_cast<size_t>((v[2] - k0) * cell + y) * w + (v[0] - i0) * cell + x) * 3;
        for (int c = 0; c < 3; ++c) pixels[at + c] = static_cast<float>(std::max(0.0, L[c]));
        luma.push_back(luminance(L));
      }
  }
  const image::AutoExposure exposure = image::auto_exposure(std::move(luma));
  const std::string rule = image::describe_exposure(exposure, "sphere pixel", "every probe is black");
  image::Png8Image png = image::display_png8(std::move(pixels), w, h, exposure.multiplier, color_space);
  png.metadata["Description"] = "kiln light probes: white diffuse spheres lit by the probes of layer y = " +
                                format_number(r.placement.origin.y + layer * r.placement.spacing) +
                                ", seen from above (+x right, +z down), exposure " + rule;
  png.metadata["kiln:exposure"] = format_number(exposure.multiplier);
  png.metadata["kiln:exposure_rule"] = rule;
  return {"probes_preview.png", "image/png", "srgb_display", image::encode_png(png)};
}

}  // namespace

Rgb probe_irradiance(const ProbeSh& sh, const Vec3& n) {
  envmap::ShCoefficients L;
  std::copy(sh.begin(), sh.end(), L.begin());
  return envmap::evaluate_sh(envmap::sh_radiance_to_irradiance(L), n);
}

std::vector<bake::BakeOutput> probe_volume_outputs(const ProbeVolumeResult& r, const std::string& color_space) {
  volume::ProbeLattice lattice{r.placement.origin, r.placement.spacing, r.placement.voxels};
  // No probe placed: the lattice still needs a voxel size for the file's transform.
  if (!(lattice.voxel_size > 0)) lattice.voxel_size = 1;
  const std::vector<uint8_t> vdb = volume::write_probe_vdb(lattice, probe_grids(r), file_metadata(r, color_space));
  std::vector<bake::BakeOutput> out;
  out.push_back({"probes.vdb", "application/x-openvdb", "scene_linear", std::string(vdb.begin(), vdb.end())});
  if (r.options.preview) out.push_back(preview(r, color_space));
  return out;
}

std::string probe_report_json(const ProbeVolumeResult& r) {
  const ProbePlacement& p = r.placement;
  Json j;
  j["spacing"] = p.spacing;
  j["requested_spacing"] = r.options.spacing;
  j["max_distance"] = r.options.distance();
  j["max_probes"] = r.options.max_probes;
  j["origin"] = {p.origin.x, p.origin.y, p.origin.z};
  Json regions = Json::array();
  for (const ProbeBox& b : p.regions)
    regions.push_back({{"lo", {b.lo.x, b.lo.y, b.lo.z}}, {"hi", {b.hi.x, b.hi.y, b.hi.z}}});
  j["regions"] = regions;
  j["counts"] = {{"lattice_points", p.lattice_points},
                 {"placed", p.voxels.size()},
                 {"valid", r.valid},
                 {"invalid_inside_geometry", r.invalid},
                 {"skipped_far_from_geometry", p.skipped_far}};
  j["samples"] = r.samples;
  j["rays"] = r.rays;
  j["dropped_samples"] = r.dropped;
  j["rounds"] = r.rounds;
  j["seconds"] = {{"placement", r.placement_seconds}, {"sampling", r.sampling_seconds}};
  uint64_t most = 0, least = r.samples_per_probe.empty() ? 0 : UINT64_MAX;
  for (uint64_t s : r.samples_per_probe) most = std::max(most, s), least = std::min(least, s);
  j["samples_per_probe"] = {{"min", least}, {"max", most}};
  j["error"] = {{"metric", to_string(r.sampling.stopping.metric)},
                {"target", r.sampling.stopping.target_error},
                {"brightness", r.brightness},
                {"rms", r.rms_error},
                {"max", r.max_error},
                {"above_target", r.above_target}};
  Json decisions = p.reasons;
  if (r.probes.empty()) {
    decisions.push_back("no probe was placed: nothing to sample (widen the regions or max_distance)");
  } else if (r.out_of_time) {
    decisions.push_back("the time limit ended the sampling with " + std::to_string(r.above_target) +
                        " valid probes above the target error");
  } else if (r.above_target > 0) {
    decisions.push_back(std::to_string(r.above_target) + " valid probes reached max_samples (" +
                        std::to_string(r.sampling.stopping.max_samples) + ") above the target error");
  } else {
    decisions.push_back("every valid probe reached the target error " +
                        format_number(r.sampling.stopping.target_error));
  }
  decisions.push_back("probes seeing back faces in more than " + format_number(kProbeBackFaceTolerance) +
                      " of their sampled directions are inside geometry: invalid, SH 0");
  j["decisions"] = decisions;
  return j.dump(2);
}

}  // namespace kiln::lightmap
