#include "tests/support/hemisphere.h"

#include <algorithm>
#include <cmath>

#include "bakers/math/constants.h"
#include "bakers/math/quadrature.h"

namespace kiln::test {

Vec3 spherical_direction(double theta, double phi) {
  const double s = std::sin(theta);
  return {s * std::cos(phi), s * std::sin(phi), std::cos(theta)};
}

double spherical_theta(const Vec3& w) { return std::acos(std::clamp(w.z, -1.0, 1.0)); }

double spherical_phi(const Vec3& w) {
  const double p = std::atan2(w.y, w.x);
  // atan2 gives (−π, π]; shift to [0, 2π). A tiny negative angle can round to exactly 2π: fold it to 0.
  const double q = p < 0 ? p + 2.0 * kPi : p;
  return q >= 2.0 * kPi ? 0.0 : q;
}

namespace {

std::vector<double> sorted_unique(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  v.erase(std::unique(v.begin(), v.end()), v.end());
  return v;
}

QuadratureRule composite(const std::vector<double>& breaks, int panels, int order) {
  QuadratureRule out;
  for (size_t k = 0; k + 1 < breaks.size(); ++k) {
    const QuadratureRule r = composite_gauss_legendre(order, panels, breaks[k], breaks[k + 1]);
    out.nodes.insert(out.nodes.end(), r.nodes.begin(), r.nodes.end());
    out.weights.insert(out.weights.end(), r.weights.begin(), r.weights.end());
  }
  return out;
}

// The reference rule on [-1, 1], computed once per order.
const QuadratureRule& unit_rule(int order) {
  static thread_local std::vector<QuadratureRule> cache;
  if (static_cast<int>(cache.size()) <= order) cache.resize(order + 1);
  if (cache[order].nodes.empty()) cache[order] = gauss_legendre(order, -1.0, 1.0);
  return cache[order];
}

double cell_rule(const DirectionFunction& f, double t0, double t1, double p0, double p1, int order, int64_t& evals) {
  const QuadratureRule& r = unit_rule(order);
  const double ht = 0.5 * (t1 - t0), mt = 0.5 * (t1 + t0);
  const double hp = 0.5 * (p1 - p0), mp = 0.5 * (p1 + p0);
  double sum = 0;
  for (int i = 0; i < order; ++i) {
    const double theta = mt + ht * r.nodes[i];
    const double st = std::sin(theta), ct = std::cos(theta);
    double row = 0;
    for (int j = 0; j < order; ++j) {
      const double phi = mp + hp * r.nodes[j];
      row += r.weights[j] * f(Vec3{st * std::cos(phi), st * std::sin(phi), ct});
    }
    sum += r.weights[i] * st * row;
  }
  evals += static_cast<int64_t>(order) * order;
  return sum * ht * hp;
}

// `tol` is an absolute tolerance for this piece: the whole cell's max(rel_tol·|value|, abs_tol), quartered at every
// level so that the accepted pieces' tolerances sum to at most the cell's.
void refine(const DirectionFunction& f, double t0, double t1, double p0, double p1, double coarse, double tol,
            int order, int depth, CellIntegral& out) {
  const double tm = 0.5 * (t0 + t1), pm = 0.5 * (p0 + p1);
  const double q[4] = {
      cell_rule(f, t0, tm, p0, pm, order, out.evaluations), cell_rule(f, tm, t1, p0, pm, order, out.evaluations),
      cell_rule(f, t0, tm, pm, p1, order, out.evaluations), cell_rule(f, tm, t1, pm, p1, order, out.evaluations)};
  const double fine = q[0] + q[1] + q[2] + q[3];
  const double diff = std::fabs(fine - coarse);
  if (diff <= tol || depth <= 0) {
    if (diff > tol) out.depth_limited = true;
    out.value += fine;
    out.error += diff;
    return;
  }
  refine(f, t0, tm, p0, pm, q[0], 0.25 * tol, order, depth - 1, out);
  refine(f, tm, t1, p0, pm, q[1], 0.25 * tol, order, depth - 1, out);
  refine(f, t0, tm, pm, p1, q[2], 0.25 * tol, order, depth - 1, out);
  refine(f, tm, t1, pm, p1, q[3], 0.25 * tol, order, depth - 1, out);
}

}  // namespace

DirectionRule direction_rule(const std::vector<double>& theta_breaks, const std::vector<double>& phi_breaks, int panels,
                             int order) {
  const QuadratureRule rt = composite(sorted_unique(theta_breaks), panels, order);
  const QuadratureRule rp = composite(sorted_unique(phi_breaks), panels, order);
  DirectionRule rule;
  rule.directions.reserve(rt.nodes.size() * rp.nodes.size());
  rule.weights.reserve(rt.nodes.size() * rp.nodes.size());
  for (size_t i = 0; i < rt.nodes.size(); ++i) {
    const double st = std::sin(rt.nodes[i]);
    for (size_t j = 0; j < rp.nodes.size(); ++j) {
      rule.directions.push_back(spherical_direction(rt.nodes[i], rp.nodes[j]));
      rule.weights.push_back(rt.weights[i] * rp.weights[j] * st);
    }
  }
  return rule;
}

DirectionRule hemisphere_rule(int panels, int order, std::vector<double> extra_theta_breaks,
                              std::vector<double> extra_phi_breaks) {
  std::vector<double> tb{0.0, kPiOver2}, pb{0.0, 2.0 * kPi};
  for (double t : extra_theta_breaks)
    if (t > 0 && t < kPiOver2) tb.push_back(t);
  for (double p : extra_phi_breaks)
    if (p > 0 && p < 2.0 * kPi) pb.push_back(p);
  return direction_rule(tb, pb, panels, order);
}

double integrate(const DirectionRule& rule, const DirectionFunction& f) {
  double sum = 0;
  for (size_t k = 0; k < rule.directions.size(); ++k) sum += rule.weights[k] * f(rule.directions[k]);
  return sum;
}

CellIntegral integrate_cell(const DirectionFunction& f, double theta0, double theta1, double phi0, double phi1,
                            double rel_tol, double abs_tol, int order, int max_depth) {
  CellIntegral out;
  const double coarse = cell_rule(f, theta0, theta1, phi0, phi1, order, out.evaluations);
  refine(f, theta0, theta1, phi0, phi1, coarse, std::max(rel_tol * std::fabs(coarse), abs_tol), order, max_depth, out);
  return out;
}

}  // namespace kiln::test
