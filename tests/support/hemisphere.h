// Deterministic integration over the hemisphere of directions (local frame, normal +z), for test references:
// expected chi-square counts, pdf normalisation, directional albedos by quadrature.
//
// Everything is parameterised by spherical angles (θ, φ) with the solid-angle element sin θ dθ dφ. θ rather than
// cos θ because θ resolves lobes at the pole (a lobe of width w around the normal spans w²/2 in cos θ, w in θ).
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "bakers/math/vec3.h"

namespace kiln::test {

// The unit vector with polar angle theta from +z and azimuth phi from +x.
Vec3 spherical_direction(double theta, double phi);
// θ ∈ [0, π] of a unit vector (clamped against rounding), and φ ∈ [0, 2π).
double spherical_theta(const Vec3& w);
double spherical_phi(const Vec3& w);

using DirectionFunction = std::function<double(const Vec3&)>;

// A tensor-product composite Gauss–Legendre rule on the (θ, φ) rectangle spanned by the breakpoints: every interval
// between consecutive breakpoints is split into `panels` equal panels with an `order`-point rule on each. Put
// breakpoints where the integrand has kinks or jumps (e.g. θ = θo for Oren–Nayar's max/min), so that the rule only
// integrates smooth pieces and converges at its full order. The weights include the Jacobian sin θ.
struct DirectionRule {
  std::vector<Vec3> directions;
  std::vector<double> weights;
};
DirectionRule direction_rule(const std::vector<double>& theta_breaks, const std::vector<double>& phi_breaks, int panels,
                             int order);
// The upper hemisphere θ ∈ [0, π/2], φ ∈ [0, 2π] with extra θ and φ breakpoints (added to the ends; any order).
DirectionRule hemisphere_rule(int panels, int order, std::vector<double> extra_theta_breaks = {},
                              std::vector<double> extra_phi_breaks = {});
double integrate(const DirectionRule& rule, const DirectionFunction& f);

// Adaptive integration of f over one (θ, φ) cell: a 2-D Gauss–Legendre rule of `order`² nodes on the cell is compared
// with the same rule on its four quarters; where they differ by more than the piece's tolerance the quarters are
// refined in turn, down to max_depth. The cell's tolerance is max(rel_tol·|estimate on the cell|, abs_tol), and each
// quarter gets a quarter of its parent's, so the accepted pieces' tolerances sum to at most the cell's (kinks and
// jumps along a curve only refine the pieces they cross). `error` sums |fine − coarse| of the accepted pieces: a
// conservative bound on the error of `value` (the finer of the two estimates) for integrands smooth at the scale of
// the accepted pieces.
struct CellIntegral {
  double value = 0;
  double error = 0;
  int64_t evaluations = 0;
  bool depth_limited = false;  // some piece hit max_depth without meeting the tolerance
};
CellIntegral integrate_cell(const DirectionFunction& f, double theta0, double theta1, double phi0, double phi1,
                            double rel_tol, double abs_tol, int order = 3, int max_depth = 8);

}  // namespace kiln::test
