// Every numeric bound of the protocol, declared once. The client's flag parser, the daemon's translation layer and
// the bakers' own validation read them from here, so that a bound cannot drift between layers. Plain constants and
// no protobuf, so that bakers/ (which knows nothing of the wire) may include it too; kiln.proto's comments state the
// same bounds for people.
#pragma once

#include <cstdint>

namespace kiln::bounds {

// A real number in [lo, hi], or in (lo, hi] with lo_open. NaN is outside every range.
struct Range {
  double lo = 0;
  double hi = 0;
  bool lo_open = false;
  constexpr bool contains(double v) const { return (lo_open ? v > lo : v >= lo) && v <= hi; }
};

// A whole number in [lo, hi].
struct WholeRange {
  int64_t lo = 0;
  int64_t hi = 0;
  constexpr bool contains(int64_t v) const { return v >= lo && v <= hi; }
  // The same bounds as a Range, for checks of a number the wire carries as a double.
  constexpr Range real() const { return Range{static_cast<double>(lo), static_cast<double>(hi)}; }
};

// --- BRDF parameters (material jobs and lightmap material overrides) ------------------------------------------------
inline constexpr Range kAlpha{0.0, 1.0, true};           // microfacet width α (alpha, alpha_x, alpha_y)
inline constexpr Range kReflectance{0.0, 1.0};           // albedo, f0, Schlick's c, base colour: each channel
inline constexpr Range kEta{0.1, 10.0};                  // relative index of refraction (diamond in air: 2.42)
inline constexpr Range kSigma{0.0, 1.5707963267948966};  // Oren–Nayar slope deviation σ in radians, [0, π/2]
inline constexpr Range kSchlickParameter{0.0, 1.0};      // Schlick's roughness r and isotropy p
inline constexpr Range kSpecularWeight{0.0, 1.0};        // a two-lobe material's weight of its specular lobe

// --- Every job -------------------------------------------------------------------------------------------------------
inline constexpr WholeRange kSeed{0, int64_t{1} << 53};  // exact in a double, so every client can send it
inline constexpr WholeRange kPriority{-100, 100};
inline constexpr WholeRange kListJobsLimit{0, 1000};  // jobs a ListJobs answer holds; 0: the server's default

// --- Material jobs ---------------------------------------------------------------------------------------------------
inline constexpr WholeRange kTableSize{2, 1024};           // table_mu and table_roughness
inline constexpr WholeRange kMaterialSamples{1, 1 << 24};  // per table entry
inline constexpr Range kMaterialTargetError{0.0, 1.0, true};
inline constexpr Range kMaterialTimeLimitSeconds{0.0, 86400.0, true};

// --- Environment jobs ------------------------------------------------------------------------------------------------
inline constexpr WholeRange kCubeSize{4, 2048};  // and a power of two
inline constexpr WholeRange kLevels{1, 10};      // and at most log2(size / 4) + 1 for the cube's size
inline constexpr WholeRange kIrradianceSize{1, 256};
inline constexpr WholeRange kDfgSize{2, 1024};
inline constexpr WholeRange kDfgSamples{16, 1 << 20};
inline constexpr WholeRange kEnvironmentSamples{4, 65536};  // per texel of a prefiltered level
inline constexpr Range kEnvironmentTargetError{1e-4, 1.0};
inline constexpr Range kRotationDegrees{-360.0, 360.0};
inline constexpr Range kEnvironmentIntensity{0.0, 1e6, true};
inline constexpr Range kEnvironmentConstant{0.0, 1e6};  // radiance, each channel

// --- Lightmap jobs ---------------------------------------------------------------------------------------------------
inline constexpr WholeRange kLightmapResolution{4, 8192};  // texels on a side
inline constexpr WholeRange kLightmapPadding{0, 64};       // texels of dilation
inline constexpr WholeRange kMaxBounces{0, 1024};
inline constexpr WholeRange kLightmapSamples{1, 1 << 20};  // per texel
inline constexpr Range kLightmapTargetError{0.0, 1.0, true};
inline constexpr Range kLightmapTimeLimitSeconds{0.0, 7 * 86400.0, true};
// Atlas packing (bakers/lightmap/atlas_pack.h): texels per metre of surface (per scene unit), texels on a side of a
// page, pages per job.
inline constexpr Range kTexelDensity{0.0, 1e6, true};
inline constexpr WholeRange kAtlasPageSize{16, 8192};
inline constexpr WholeRange kAtlasMaxPages{1, 4096};
// The most memory a bake may hold, bytes: 64 MiB to 1 PiB.
inline constexpr WholeRange kLightmapMemoryLimit{int64_t{1} << 26, int64_t{1} << 50};

// --- Participating media (LightmapJob.media; docs/MEDIA.md) ---------------------------------------------------------
inline constexpr WholeRange kLightmapMedia{0, 16};  // media in one job
// sigma_a and sigma_s each channel, per metre (per scene unit); for a VDB medium, per unit of density. 1e6 m^-1 is a
// mean free path of a micrometre: opaque at any scene scale.
inline constexpr Range kMediumCoefficient{0.0, 1e6};
// Henyey-Greenstein asymmetry g; +-1 (a Dirac delta) is accepted and narrowed by the phase function.
inline constexpr Range kMediumAsymmetry{-1.0, 1.0};
inline constexpr Range kMediumEmission{0.0, 1e6};  // emitted radiance Le (or the scale of an emission grid)
// A VDB blob: its bytes, the active voxels of each grid read from it, the extent of a grid's active voxels in voxels
// along each axis, and the world-space size of a voxel (the grid's own transform, before the medium's).
inline constexpr WholeRange kVdbBytes{1, int64_t{256} << 20};
inline constexpr WholeRange kVdbActiveVoxels{0, int64_t{1} << 26};
inline constexpr WholeRange kVdbExtentVoxels{1, 1 << 16};
inline constexpr Range kVdbVoxelSize{0.0, 1e6, true};

// --- Light probes (ProbeVolume, in a ProbesJob or LightmapJob.probes; docs/PROBES.md) -------------------------------
inline constexpr WholeRange kProbeRegions{0, 16};            // boxes in one volume
inline constexpr Range kProbeCoordinate{-1e9, 1e9};          // each coordinate of a region's corners
inline constexpr Range kProbeSpacing{0.0, 1e6, true};        // between neighbouring probes, scene units
inline constexpr Range kProbeMaxDistance{0.0, 1e6};          // from the nearest triangle
inline constexpr WholeRange kProbeCount{1, int64_t{1} << 22};  // max_probes: 2^22 probes: 16 GiB by the estimate
inline constexpr int64_t kDefaultMaxProbes = int64_t{1} << 18;

}  // namespace kiln::bounds
