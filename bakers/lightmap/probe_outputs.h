// What a probe volume writes (docs/PROBES.md): probes.vdb, probes_preview.png and report.json's "probes" object.
//
// probes.vdb: float grids sh<K>_<r|g|b> (K = 0..8) holding the radiance SH coefficients L_K of envmap/sh.h's basis
// (real, orthonormal, no Condon–Shortley phase, world axes, +Y up), RGB in the working space, W·m⁻²·sr⁻¹ per unit
// basis function; "validity" (1 valid, 0 inside geometry) and "error" (the probe's relative error under the job's
// metric). One active voxel per placed probe in every grid; voxel size = spacing, index (0, 0, 0) at the lattice's
// origin. String metadata on the file and on every grid say so (kProbeMetadata keys), so an engine needs no kiln.
// The irradiance for a normal n is E(n) = Σ_K Â_l(K) L_K Y_K(n), Â = (π, 2π/3, π/4).
#pragma once

#include <string>
#include <vector>

#include "bakers/bake/output.h"
#include "bakers/lightmap/probe_volume.h"

namespace kiln::lightmap {

// probes.vdb, then probes_preview.png when the options ask for it.
std::vector<bake::BakeOutput> probe_volume_outputs(const ProbeVolumeResult& r, const std::string& color_space);

// The JSON text of report.json's "probes" object: counts (placed, valid, invalid inside geometry, skipped far from
// geometry), samples, rays, time, the error summary and the placement's and sampling's decisions with their reasons.
std::string probe_report_json(const ProbeVolumeResult& r);

// The irradiance a probe's radiance SH gives for normal n (order-2 reconstruction with the clamped cosine).
Rgb probe_irradiance(const ProbeSh& sh, const Vec3& n);

}  // namespace kiln::lightmap
