// Order-2 real spherical harmonics (l ≤ 2, nine coefficients) for diffuse irradiance, after Ramamoorthi & Hanrahan,
// "An Efficient Representation for Irradiance Environment Maps" (SIGGRAPH 2001).
//
// Basis (index i = l(l + 1) + m), written in world coordinates of a unit direction (x, y, z) (+Y up, the cube-map
// conventions of cubemap.h); orthonormal on the sphere, ∫ Y_i Y_j dω = δ_ij, without the Condon–Shortley phase
// (all constants positive, as in Ramamoorthi & Hanrahan's equation 3):
//   Y0 = Y00  = 1 / (2 √π)                        = 0.282095
//   Y1 = Y1-1 = √(3 / 4π) y                       = 0.488603 y
//   Y2 = Y10  = √(3 / 4π) z                       = 0.488603 z
//   Y3 = Y11  = √(3 / 4π) x                       = 0.488603 x
//   Y4 = Y2-2 = √(15 / 4π) x y                    = 1.092548 xy
//   Y5 = Y2-1 = √(15 / 4π) y z                    = 1.092548 yz
//   Y6 = Y20  = √(5 / 16π) (3 z² − 1)             = 0.315392 (3z² − 1)
//   Y7 = Y21  = √(15 / 4π) x z                    = 1.092548 xz
//   Y8 = Y22  = √(15 / 16π) (x² − y²)             = 0.546274 (x² − y²)
// (The formulas' polar axis is world z; the basis spans the same space whichever axis is up, and a rotation of the
// environment mixes coefficients only within each band l.)
//
// Radiance coefficients L_i = ∫ L(ω) Y_i(ω) dω. The clamped cosine max(0, n·ω) has the zonal coefficients
// Â_0 = π, Â_1 = 2π/3, Â_2 = π/4 (R&H 2001, equation 8) in the sense E(n) = Σ_i Â_l(i) L_i Y_i(n): the irradiance
// coefficients E_i = Â_l(i) L_i fold the cosine lobe in, and E(n) = Σ_i E_i Y_i(n) in W·m⁻².
#pragma once

#include <array>
#include <string_view>

#include "bakers/envmap/cubemap.h"
#include "bakers/math/rgb.h"
#include "bakers/math/vec3.h"

namespace kiln::envmap {

inline constexpr int kShCount = 9;
using ShBasis = std::array<double, kShCount>;
using ShCoefficients = std::array<Rgb, kShCount>;

// One header line for sh.txt and metadata: the basis, its normalisation and what the coefficients hold.
inline constexpr std::string_view kShIrradianceHeader =
    "# real SH l<=2, orthonormal (int Y_i Y_j dw = delta_ij), no Condon-Shortley phase, unit direction (x,y,z), +Y "
    "up; Y0=0.282095 Y1=0.488603y Y2=0.488603z Y3=0.488603x Y4=1.092548xy Y5=1.092548yz Y6=0.315392(3z^2-1) "
    "Y7=1.092548xz Y8=0.546274(x^2-y^2); coefficients are irradiance E_i = A_l L_i (A0=pi, A1=2pi/3, A2=pi/4), "
    "E(n) = sum_i E_i Y_i(n), RGB in W m^-2";

// The nine basis functions at a unit direction.
ShBasis sh_basis(const Vec3& dir);
// Â_l of the clamped cosine for band l = 0, 1, 2 (π, 2π/3, π/4).
double sh_cosine_lobe(int l);
// Band of coefficient index i (0 for i = 0, 1 for 1..3, 2 for 4..8).
inline constexpr int sh_band(int i) { return i == 0 ? 0 : (i < 4 ? 1 : 2); }

// Radiance coefficients of a cubemap: L_i = Σ_texels L · Y_i(texel centre) · ΔΩ with the exact texel solid angles
// (the midpoint rule on each texel: error O(1/size²) for smooth environments).
ShCoefficients project_sh(const Cubemap& cube);
// Irradiance coefficients E_i = Â_l L_i from radiance coefficients.
ShCoefficients sh_radiance_to_irradiance(const ShCoefficients& radiance);
// Σ_i c_i Y_i(dir): the irradiance E(n) when `c` holds irradiance coefficients, the band-limited radiance otherwise.
Rgb evaluate_sh(const ShCoefficients& c, const Vec3& dir);

}  // namespace kiln::envmap
