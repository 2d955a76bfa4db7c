// A BRDF tabulated in the MERL binary layout (Matusik et al. 2003), so that tools reading measured BRDFs open it.
//
// File: three int32 dimensions 90, 90, 180, then 3 blocks (R, G, B) of 90·90·180 doubles, little-endian. Entry
// (i_h, i_d, i_p) sits at i_p + 180 (i_d + 90 i_h) of each block. Stored value = f / scale with the MERL scale
// factors 1/1500, 1.15/1500, 1.66/1500 for R, G, B (a reader multiplies by them to get f in 1/sr).
//
// Coordinates (Rusinkiewicz 1998): θ_h, φ_h of the half vector h = normalize(wi + wo), and θ_d, φ_d of wi in the
// frame where h is the pole (wi rotated by −φ_h about the normal, then by −θ_h about the binormal). φ_h is dropped
// (isotropy) and φ_d is folded into [0, π) (φ_d and φ_d + π swap wi and wo: reciprocity). Continuous indices:
//   θ_h: sqrt(θ_h / (π/2)) · 90   (non-linear: dense near the specular peak)
//   θ_d: θ_d / (π/2) · 90
//   φ_d: φ_d / π · 180
// Bin convention: MERL's reader (BRDFRead.cpp, lookup_brdf_val) truncates each continuous index to an integer
// (int cast, clamped to the last bin), so entry i stands for the whole cell [i, i + 1) of the index. We tabulate
// every cell at its centre i + 0.5, so that the reader's lookup is off by at most half a cell in each coordinate
// (sampling at i, the cell's lower edge, would bias every lookup by up to a whole cell). Tools that interpolate
// between entries as if they sat at integer indices see a half-cell shift.
// Cells wholly below the horizon hold 0, the model's value there (measured MERL files hold negative markers
// instead). A cell whose centre is below the horizon but which reaches above it holds the mean of f over its part
// above the horizon (on a grid in the cell, see merl.cpp), so that a lookup just above the horizon does not find 0.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "bakers/brdf/bxdf.h"
#include "bakers/math/rgb.h"
#include "bakers/math/vec3.h"

namespace kiln::material {

inline constexpr int kMerlThetaH = 90, kMerlThetaD = 90, kMerlPhiD = 180;
inline constexpr size_t kMerlEntries = size_t{kMerlThetaH} * kMerlThetaD * kMerlPhiD;  // 1 458 000
inline constexpr size_t kMerlFileBytes = 12 + 8 * 3 * kMerlEntries;                    // 34 992 012
// MERL's per-channel scale factors: file value × scale = f in 1/sr.
inline constexpr double kMerlScale[3] = {1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0};

struct MerlTable {
  std::vector<Rgb> f;  // kMerlEntries values of f in 1/sr (the scale already applied), index merl_index(...)
  const Rgb& at(int i_h, int i_d, int i_p) const { return f[merl_index(i_h, i_d, i_p)]; }
  static size_t merl_index(int i_h, int i_d, int i_p) {
    return static_cast<size_t>(i_p) + kMerlPhiD * (static_cast<size_t>(i_d) + kMerlThetaD * static_cast<size_t>(i_h));
  }
};

struct MerlOptions {
  // MERL is isotropic. For an anisotropic model, average f over this many evenly spaced azimuths φ_h of the half
  // vector; 1 evaluates at φ_h = 0 only (exact for isotropic models).
  int phi_h_samples = 1;
  // MERL is reciprocal. For a model that is not (Bxdf::reciprocal() false), store (f(wo, wi) + f(wi, wo)) / 2.
  bool symmetrize_if_not_reciprocal = true;
  // Called after each θ_h row from the worker threads, possibly concurrently; it may throw to abandon the
  // tabulation (the exception reaches the caller of tabulate_merl).
  std::function<void()> row_done;
};

// The directions of a cell centre: wi is MERL's "in" vector, wo its mirror about h (φ_h = 0 unless given).
struct MerlDirections {
  Vec3 wo, wi;
};
MerlDirections merl_directions(double theta_h, double theta_d, double phi_d, double phi_h = 0.0);
// Continuous indices (θ_h, θ_d, φ_d) of a direction pair, before truncation, as MERL's reader computes them.
struct MerlCoordinates {
  double theta_h = 0, theta_d = 0, phi_d = 0;  // angles, φ_d folded into [0, π)
  double index_h = 0, index_d = 0, index_p = 0;
};
MerlCoordinates merl_coordinates(const Vec3& wo, const Vec3& wi);

// Fills the table with both cores (TBB) from cell centres.
MerlTable tabulate_merl(const brdf::Bxdf& bxdf, const MerlOptions& options = {});
std::string encode_merl(const MerlTable& table);
std::string encode_merl(const brdf::Bxdf& bxdf, const MerlOptions& options = {});

// Reads a MERL file. Throws std::runtime_error saying what is wrong when the dimensions are not 90 × 90 × 180, the
// size is not exactly kMerlFileBytes, or a value is NaN or infinite. Negative values (MERL's marker for
// configurations that were not measured) are kept.
MerlTable decode_merl(const std::string& bytes);

// f(wo, wi) as MERL's reader looks it up: truncated indices, no interpolation; wi is the "in" vector. Directions at
// or below the horizon, and negative (unmeasured) entries, give 0.
Rgb lookup(const MerlTable& table, const Vec3& wo, const Vec3& wi);

}  // namespace kiln::material
