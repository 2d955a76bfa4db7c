// Oren–Nayar, full first-order model (with and without the two-bounce term) and the simplified A/B model.
//
// References used here, none of them the code's own earlier output:
//  - Lambert (σ = 0 must reproduce it bit for bit);
//  - the paper's formula transcribed from angles (θ, φ) with std::tan/std::cos, an evaluation path independent of
//    the model's component-based one;
//  - closed forms: f at normal incidence (β = 0), the backscatter plane (Δφ = 0, where the two models coincide),
//    the albedo of the two-bounce term (its azimuthal integral is exact: E2 = 0.17 ρ² σ²/(σ² + 0.13) for every θo);
//  - directional albedos by deterministic Gauss–Legendre quadrature in (θ_i, φ), and an independent 1-D reference in
//    which the azimuthal integral is done analytically (∫ cos Δφ over the two C2 branches, ∫ (1 − |cos Δφ|) = 2π − 4).
#include "bakers/brdf/oren_nayar.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "bakers/brdf/lambert.h"
#include "bakers/math/constants.h"
#include "bakers/math/quadrature.h"
#include "bakers/math/rng.h"
#include "bakers/math/sampling.h"

namespace kiln::brdf {
namespace {

constexpr double kDeg = kPi / 180.0;

Vec3 direction(double theta, double phi) {
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

double sq(double x) { return x * x; }

// ---- The paper's formulas, transcribed from angles (independent of the model's vector code) -------------------------

double ratio(double sigma, double k) { return sigma * sigma / (sigma * sigma + k); }
double c1(double sigma) { return 1.0 - 0.5 * ratio(sigma, 0.33); }
double b_coeff(double sigma) { return 0.45 * ratio(sigma, 0.09); }

// The bracket of the first-order model, unclamped: f1 = ρ/π · bracket.
struct Bracket {
  double value;
  double magnitude;  // sum of the absolute values of its terms, the scale of its rounding error
};
Bracket paper_first_order(double sigma, double theta_o, double theta_i, double dphi) {
  const double alpha = std::max(theta_o, theta_i), beta = std::min(theta_o, theta_i);
  const double cos_dphi = std::cos(dphi);
  const double c2 = cos_dphi >= 0 ? b_coeff(sigma) * std::sin(alpha)
                                  : b_coeff(sigma) * (std::sin(alpha) - std::pow(2.0 * beta / kPi, 3));
  const double c3 = 0.125 * ratio(sigma, 0.09) * sq(4.0 * alpha * beta / (kPi * kPi));
  const double t1 = c1(sigma), t2 = cos_dphi * c2 * std::tan(beta);
  const double t3 = (1.0 - std::fabs(cos_dphi)) * c3 * std::tan((alpha + beta) / 2.0);
  return {t1 + t2 + t3, std::fabs(t1) + std::fabs(t2) + std::fabs(t3)};
}
// The two-bounce term without ρ²/π: 0.17 σ²/(σ²+0.13) [1 − cos Δφ (2β/π)²].
double paper_interreflection(double sigma, double theta_o, double theta_i, double dphi) {
  const double beta = std::min(theta_o, theta_i);
  return 0.17 * ratio(sigma, 0.13) * (1.0 - std::cos(dphi) * sq(2.0 * beta / kPi));
}
double paper_simple(double sigma, double theta_o, double theta_i, double dphi) {
  const double alpha = std::max(theta_o, theta_i), beta = std::min(theta_o, theta_i);
  return c1(sigma) + b_coeff(sigma) * std::max(0.0, std::cos(dphi)) * std::sin(alpha) * std::tan(beta);
}

// The smallest σ at which the first-order bracket can go negative. At cos Δφ = −1 it is C1 − C2 tan β, and
// (sin α − (2β/π)³) tan β rises to 6/π as α, β → 90° (α = β = 90° − ε: sin α − (2β/π)³ ≈ 6ε/π, tan β ≈ 1/ε).
// So the bracket has infimum C1 − (6/π) B, negative once B/C1 > π/6. Bisection on that closed form.
double sigma_where_first_order_turns_negative() {
  double lo = 0.0, hi = kPiOver2;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (c1(mid) - 6.0 / kPi * b_coeff(mid) > 0) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  return 0.5 * (lo + hi);
}

// ---- Quadrature -------------------------------------------------------------------------------------------------

struct Rule {
  std::vector<double> x, w;
  void add(int n, double a, double b) {
    const QuadratureRule q = gauss_legendre(n, a, b);
    x.insert(x.end(), q.nodes.begin(), q.nodes.end());
    w.insert(w.end(), q.weights.begin(), q.weights.end());
  }
};

struct Resolution {
  int order;   // Gauss–Legendre points per panel
  int graded;  // geometrically graded panels on [0, θo]
};
constexpr Resolution kCoarse{12, 20};
constexpr Resolution kFine{20, 34};

// Polar nodes for an integrand with a kink at θ = θo (α and β swap) and, below it, tan((θo + θ)/2) whose pole at
// θ = π − θo lies only 2(90° − θo) past θo when θo grazes: panels on [0, θo] shrink geometrically towards θo so that
// every panel is at least its own length away from the pole; [θo, π/2] is one panel, the pole lies one panel length
// past its end. Every piece is then analytic and Gauss–Legendre converges exponentially.
Rule theta_rule(double theta_o, Resolution res) {
  Rule r;
  if (theta_o > 0) {
    double lo = 0.0;
    for (int k = 1; k <= res.graded; ++k) {
      const double hi = theta_o - theta_o * std::ldexp(1.0, -k);
      r.add(res.order, lo, hi);
      lo = hi;
    }
    r.add(res.order, lo, theta_o);
  }
  r.add(2 * res.order, theta_o, kPiOver2);
  return r;
}

// E(θo) = ∫ f(wo, wi) cos θi dωi with wo at azimuth 0. f depends on φi only through cos φi, so the integral over
// [0, 2π] is twice the one over [0, π], split at π/2 where cos Δφ changes sign (C2's branches, |cos Δφ|, max(0, ·)).
Rgb albedo_quadrature(const Bxdf& model, double theta_o, Resolution res = kCoarse) {
  const Rule th = theta_rule(theta_o, res);
  Rule ph;
  ph.add(res.order, 0.0, kPiOver2);
  ph.add(res.order, kPiOver2, kPi);
  const Vec3 wo = direction(theta_o, 0.0);
  Rgb sum;
  for (size_t a = 0; a < th.x.size(); ++a) {
    Rgb inner;
    for (size_t b = 0; b < ph.x.size(); ++b) inner += model.eval(wo, direction(th.x[a], ph.x[b])) * ph.w[b];
    sum += inner * (th.w[a] * std::cos(th.x[a]) * std::sin(th.x[a]));
  }
  return sum * 2.0;
}

// The same albedos with the azimuth integrated in closed form (ρ = 1), valid where the bracket is nowhere clamped:
//   full first order: E = 1/π ∫ [2π C1 + 2 B (2β/π)³ tan β + (2π − 4) C3 tan((α+β)/2)] sin θ cos θ dθ
//   simplified:       E = 1/π ∫ [2π A + 2 B sin α tan β] sin θ cos θ dθ
// (∫ cos Δφ over cos Δφ ≥ 0 is 2 and over cos Δφ < 0 is −2, so the two C2 branches leave 2 B (2β/π)³ tan β.)
double reference_albedo_full(double sigma, double theta_o, Resolution res = kFine) {
  const Rule th = theta_rule(theta_o, res);
  double sum = 0;
  for (size_t a = 0; a < th.x.size(); ++a) {
    const double t = th.x[a];
    const double alpha = std::max(theta_o, t), beta = std::min(theta_o, t);
    const double c3 = 0.125 * ratio(sigma, 0.09) * sq(4.0 * alpha * beta / (kPi * kPi));
    const double bracket = 2.0 * kPi * c1(sigma) +
                           2.0 * b_coeff(sigma) * std::pow(2.0 * beta / kPi, 3) * std::tan(beta) +
                           (2.0 * kPi - 4.0) * c3 * std::tan((alpha + beta) / 2.0);
    sum += th.w[a] * bracket * std::sin(t) * std::cos(t);
  }
  return sum / kPi;
}
double reference_albedo_simple(double sigma, double theta_o, Resolution res = kFine) {
  const Rule th = theta_rule(theta_o, res);
  double sum = 0;
  for (size_t a = 0; a < th.x.size(); ++a) {
    const double t = th.x[a];
    const double alpha = std::max(theta_o, t), beta = std::min(theta_o, t);
    const double bracket = 2.0 * kPi * c1(sigma) + 2.0 * b_coeff(sigma) * std::sin(alpha) * std::tan(beta);
    sum += th.w[a] * bracket * std::sin(t) * std::cos(t);
  }
  return sum / kPi;
}

std::string fmt(const char* f, double a, double b = 0, double c = 0, double d = 0) {
  char buf[256];
  std::snprintf(buf, sizeof buf, f, a, b, c, d);
  return buf;
}

// Random directions on the open upper hemisphere, reproducible.
std::vector<Vec3> random_directions(int n, uint64_t seed) {
  Pcg32 rng(seed);
  std::vector<Vec3> out;
  while (static_cast<int>(out.size()) < n) {
    const Vec3 w = sample_uniform_hemisphere({rng.uniform(), rng.uniform()});
    if (w.z > 0) out.push_back(w);
  }
  return out;
}

const std::vector<double> kSigmas = {0.05, 0.2, 0.5, 0.7, 1.0, 1.5};

// ---- σ = 0 is Lambert -------------------------------------------------------------------------------------------

TEST(OrenNayar, SigmaZeroIsLambertBitForBit) {
  const Rgb rho(0.8, 0.5, 0.2);
  const Lambert lambert(rho);
  const OrenNayar full(rho, 0.0, false), full_ir(rho, 0.0, true);
  const OrenNayarSimple simple(rho, 0.0);
  std::vector<Vec3> dirs = random_directions(400, 7);
  // Special directions: the normal, near-normal, grazing cos θ = 1e-7 and a subnormal cos θ (tan θ overflows).
  dirs.push_back({0, 0, 1});
  dirs.push_back(normalize(Vec3{1e-9, 0, 1}));
  dirs.push_back({std::sqrt(1 - 1e-14), 0, 1e-7});
  dirs.push_back({-std::sqrt(1 - 1e-14), 0, 1e-7});
  dirs.push_back({1, 0, 1e-310});
  for (const Vec3& wo : dirs) {
    for (const Vec3& wi : dirs) {
      const Rgb expected = lambert.eval(wo, wi);
      // EXPECT_EQ on doubles: with σ = 0 every roughness coefficient is exactly 0 and C1 = A = 1, so the models must
      // compute exactly ρ · (1/π), not something within rounding of it.
      for (const Bxdf* m :
           {static_cast<const Bxdf*>(&full), static_cast<const Bxdf*>(&full_ir), static_cast<const Bxdf*>(&simple)}) {
        const Rgb f = m->eval(wo, wi);
        ASSERT_EQ(f.r, expected.r);
        ASSERT_EQ(f.g, expected.g);
        ASSERT_EQ(f.b, expected.b);
        ASSERT_EQ(m->pdf(wo, wi), lambert.pdf(wo, wi));
      }
    }
  }
  // Sampling too: the same warp, so the same sample and weight bit for bit.
  Pcg32 rng(11);
  for (int k = 0; k < 200; ++k) {
    const Point2 u{rng.uniform(), rng.uniform()};
    const Vec3 wo = dirs[k];
    const auto a = full.sample(wo, u, 0.5), b = lambert.sample(wo, u, 0.5);
    ASSERT_EQ(a.has_value(), b.has_value());
    if (!a) continue;
    EXPECT_EQ(a->wi, b->wi);
    EXPECT_EQ(a->f, b->f);
    EXPECT_EQ(a->pdf, b->pdf);
    EXPECT_EQ(a->weight, b->weight);
  }
}

// ---- Reciprocity ------------------------------------------------------------------------------------------------

TEST(OrenNayar, Reciprocity) {
  const Rgb rho(0.9, 0.6, 0.3);
  const std::vector<Vec3> a = random_directions(2000, 21), b = random_directions(2000, 22);
  for (double sigma : kSigmas) {
    const OrenNayar full(rho, sigma, false), full_ir(rho, sigma, true);
    const OrenNayarSimple simple(rho, sigma);
    for (size_t k = 0; k < a.size(); ++k) {
      for (const Bxdf* m :
           {static_cast<const Bxdf*>(&full), static_cast<const Bxdf*>(&full_ir), static_cast<const Bxdf*>(&simple)}) {
        const Rgb f = m->eval(a[k], b[k]), g = m->eval(b[k], a[k]);
        for (int c = 0; c < 3; ++c) {
          // Relative 1e-14 (a few tens of ulps): the model takes min/max of per-direction quantities and forms
          // cos Δφ with commutative products, so it is symmetric by construction; the tolerance only allows for a
          // reassociated sum, and a real asymmetry (say α and β swapped in one term) shows at 1e-3 or more.
          EXPECT_NEAR(f[c], g[c], 1e-14 * std::max(f[c], g[c])) << m->describe() << " k=" << k;
        }
      }
    }
  }
}

// ---- The paper's formula -------------------------------------------------------------------------------------------

TEST(OrenNayar, MatchesThePapersFormulaWrittenWithAngles) {
  const double rho = 0.7;
  Pcg32 rng(5);
  int clamped = 0;
  for (int k = 0; k < 20000; ++k) {
    // θ up to 89°: beyond that the angle formula's own std::tan((α+β)/2) loses digits, not the model's.
    const double to = 89.0 * kDeg * rng.uniform(), ti = 89.0 * kDeg * rng.uniform();
    const double po = 2 * kPi * rng.uniform(), pi = 2 * kPi * rng.uniform();
    const double sigma = 1.5 * rng.uniform();
    const Vec3 wo = direction(to, po), wi = direction(ti, pi);

    const Bracket br = paper_first_order(sigma, to, ti, po - pi);
    // The one departure from the paper: a negative first-order bracket (σ ≳ 0.65 rad, forward scattering near the
    // horizon) is clamped at zero.
    if (br.value < 0) ++clamped;
    const double f1 = rho * kInvPi * std::max(0.0, br.value);
    const double f2 = rho * rho * kInvPi * paper_interreflection(sigma, to, ti, po - pi);
    // Tolerance 1e-12 relative to the size of the terms: the two paths differ in rounding only (a few ulps on each
    // term, times the condition number of tan at 89°, < 100); a formula error shows at 1e-3 or more.
    const double tol = 1e-12 * rho * kInvPi * (br.magnitude + 1.0);
    EXPECT_NEAR(OrenNayar(Rgb(rho), sigma, false).eval(wo, wi).r, f1, tol) << to << " " << ti << " " << sigma;
    EXPECT_NEAR(OrenNayar(Rgb(rho), sigma, true).eval(wo, wi).r, f1 + f2, tol) << to << " " << ti << " " << sigma;
    const double fs = rho * kInvPi * paper_simple(sigma, to, ti, po - pi);
    EXPECT_NEAR(OrenNayarSimple(Rgb(rho), sigma).eval(wo, wi).r, fs, 1e-12 * fs);
  }
  std::cout << "[ measured ] first-order bracket negative (clamped) in " << clamped << " of 20000 random samples\n";
}

TEST(OrenNayar, NormalIncidenceIsC1) {
  // β = 0 when either direction is the normal: tan β, C3 and the (2β/π)² of the two-bounce term vanish, whatever the
  // (undefined) azimuth. So f = ρ/π C1 (+ ρ²/π 0.17 σ²/(σ²+0.13)) and, for the simplified model, ρ/π A.
  const double rho = 0.6;
  const Vec3 n{0, 0, 1};
  for (double sigma : kSigmas) {
    const double expect_full = rho * kInvPi * c1(sigma);
    const double expect_ir = expect_full + rho * rho * kInvPi * 0.17 * ratio(sigma, 0.13);
    for (const Vec3& w : random_directions(50, 3)) {
      // 1e-15 relative (about 4 ulps): the same few products computed in a different order.
      EXPECT_NEAR(OrenNayar(Rgb(rho), sigma, false).eval(n, w).r, expect_full, 1e-15 * expect_full);
      EXPECT_NEAR(OrenNayar(Rgb(rho), sigma, false).eval(w, n).r, expect_full, 1e-15 * expect_full);
      EXPECT_NEAR(OrenNayar(Rgb(rho), sigma, true).eval(n, w).r, expect_ir, 1e-15 * expect_ir);
      EXPECT_NEAR(OrenNayarSimple(Rgb(rho), sigma).eval(w, n).r, expect_full, 1e-15 * expect_full);
    }
  }
}

TEST(OrenNayar, BackscatterBrightensTowardsTheHorizon) {
  // Retro-reflection (wi = wo): cos Δφ = 1, α = β = θ, so f = ρ/π [C1 + C2 sin θ tan θ] grows with θ for σ > 0:
  // the rough surface looks brighter towards its limb when lit from the viewer (the paper's vase, its Fig. 3).
  for (double sigma : kSigmas) {
    const OrenNayar full(Rgb(1), sigma, true);
    const OrenNayarSimple simple(Rgb(1), sigma);
    double prev_full = 0, prev_simple = 0;
    for (double deg = 0; deg <= 89.5; deg += 0.5) {
      const Vec3 w = direction(deg * kDeg, 0.3);
      const double f = full.eval(w, w).r, s = simple.eval(w, w).r;
      if (deg > 0) {
        EXPECT_GT(f, prev_full) << sigma << " " << deg;
        EXPECT_GT(s, prev_simple) << sigma << " " << deg;
      }
      prev_full = f;
      prev_simple = s;
    }
    // At the normal, below Lambert (C1 < 1); near the horizon, far above it.
    EXPECT_LT(full.eval(Vec3{0, 0, 1}, Vec3{0, 0, 1}).r, kInvPi * (1 + 0.17));
    EXPECT_GT(simple.eval(direction(89 * kDeg, 0), direction(89 * kDeg, 0)).r, kInvPi);
  }
}

TEST(OrenNayar, SimplifiedAgreesWithFullInTheBackscatterPlane) {
  // With Δφ = 0, (1 − |cos Δφ|) = 0 removes C3 and C2 takes its sin α branch, so the full first-order model and the
  // simplified one are the same expression: equal within rounding (1e-14 relative, a few ulps per term).
  for (double sigma : kSigmas) {
    const OrenNayar full(Rgb(1), sigma, false);
    const OrenNayarSimple simple(Rgb(1), sigma);
    for (double to = 0; to < 89.5; to += 3.7)
      for (double ti = 0; ti < 89.5; ti += 4.1) {
        const Vec3 wo = direction(to * kDeg, 1.0), wi = direction(ti * kDeg, 1.0);
        const double f = full.eval(wo, wi).r;
        EXPECT_NEAR(simple.eval(wo, wi).r, f, 1e-14 * f);
      }
  }
}

TEST(OrenNayar, SimplifiedVersusFullMeasured) {
  // Out of the plane of incidence the simplified model drops C3 and the negative (cos Δφ < 0) C2 branch; Oren & Nayar
  // offer it as a "qualitative model". Measure how far its albedo is from the full first-order one over moderate
  // roughness (σ ≤ 0.5 rad ≈ 29°, inside the ≈ 40° their fits cover) and view angles up to 60°. Figures from this
  // quadrature (accurate to < 1e-9, see AlbedoQuadratureConverges).
  double worst_moderate = 0, worst_moderate_sigma = 0, worst_moderate_theta = 0;
  for (double sigma = 0.05; sigma <= 0.5001; sigma += 0.05) {
    const OrenNayar full(Rgb(1), sigma, false);
    const OrenNayarSimple simple(Rgb(1), sigma);
    for (double deg : {0.0, 15.0, 30.0, 45.0, 60.0}) {
      const double ef = albedo_quadrature(full, deg * kDeg).r, es = albedo_quadrature(simple, deg * kDeg).r;
      const double rel = std::fabs(es - ef) / ef;
      if (rel > worst_moderate) worst_moderate = rel, worst_moderate_sigma = sigma, worst_moderate_theta = deg;
    }
  }
  const std::string msg =
      fmt("simplified vs full albedo, sigma <= 0.5 rad, theta_o <= 60 deg: max relative "
          "difference %.4f at sigma = %.2f, theta_o = %.0f deg",
          worst_moderate, worst_moderate_sigma, worst_moderate_theta);
  std::cout << "[ measured ] " << msg << "\n";
  RecordProperty("simple_vs_full", msg);
  // Measured 0.0834 at σ = 0.5, θo = 60°: the simplified model is within 8.4% of the full one in albedo there.
  // The bound is that figure rounded up; the quadrature error (< 1e-9) is irrelevant at this scale.
  EXPECT_LT(worst_moderate, 0.09);
}

// ---- The interreflection term -------------------------------------------------------------------------------------

TEST(OrenNayar, InterreflectionTerm) {
  const Rgb rho(1.0, 0.5, 0.25);
  const std::vector<Vec3> a = random_directions(500, 31), b = random_directions(500, 32);
  // Vanishes at σ = 0: exactly (its coefficient is 0 · (...) = 0).
  {
    const OrenNayar with(rho, 0.0, true), without(rho, 0.0, false);
    for (size_t k = 0; k < a.size(); ++k) EXPECT_EQ(with.eval(a[k], b[k]), without.eval(a[k], b[k]));
  }
  for (double sigma : kSigmas) {
    const OrenNayar with(rho, sigma, true), without(rho, sigma, false);
    for (size_t k = 0; k < a.size(); ++k) {
      const Rgb fw = with.eval(a[k], b[k]), fo = without.eval(a[k], b[k]);
      // Adds energy everywhere: its bracket 1 − cos Δφ (2β/π)² is ≥ 0.
      EXPECT_GT(fw.r, fo.r);
      // Scales as ρ² per channel: the added part f_with − f_without in channel c is (ρ_c/ρ_r)² times that in the red
      // channel. Each difference is of two values of size f_with, so it carries an absolute rounding error of a few
      // ulps of f_with (not of the difference): tolerance 1e-15 × the f_with values involved.
      const double d0 = fw.r - fo.r;
      for (int c = 1; c < 3; ++c) {
        const double scale = sq(rho[c] / rho.r);
        EXPECT_NEAR(fw[c] - fo[c], d0 * scale, 1e-15 * (fw[c] + fw.r * scale));
      }
    }
    // Its albedo in closed form: ∫ [1 − cos Δφ (2β/π)²] dφ = 2π for every θi, and ∫ cos θ sin θ dθ = 1/2, so
    // E2 = 0.17 ρ² σ²/(σ²+0.13) at every θo. Both albedos use the same nodes and the clamp acts on the first order
    // alone, so node by node the difference is the two-bounce term, analytic on each panel (converged to ~1e-15).
    // Tolerance 1e-10 leaves room for the rounding of the two sums.
    const double e2 = 0.17 * ratio(sigma, 0.13);
    for (double deg : {0.0, 30.0, 60.0, 85.0, 89.9}) {
      const Rgb ew = albedo_quadrature(with, deg * kDeg), eo = albedo_quadrature(without, deg * kDeg);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(ew[c] - eo[c], e2 * sq(rho[c]), 1e-10) << sigma << " " << deg;
    }
  }
}

// ---- Energy ---------------------------------------------------------------------------------------------------------

TEST(OrenNayar, AlbedoQuadratureConverges) {
  // The refinement check behind every quadrature tolerance in this file. Where the integrand is analytic on every
  // panel (no clamping: σ below the turning point ≈ 0.66 rad) the coarse and fine rules agree to ~1e-15 (measured),
  // asserted at 1e-11. Where the first-order bracket is clamped at zero (σ = 1, near grazing) the clamp's kink cuts
  // across panels and convergence is only algebraic: measured up to 8e-6 there, asserted at 2e-5.
  const double sigma_neg = sigma_where_first_order_turns_negative();
  for (double sigma : {0.13, 0.3, 0.6, 1.0}) {
    for (double deg : {0.0, 45.0, 85.0, 89.0, 89.9}) {
      const OrenNayar full(Rgb(1), sigma, true);
      const OrenNayarSimple simple(Rgb(1), sigma);
      const double df = albedo_quadrature(full, deg * kDeg, kCoarse).r - albedo_quadrature(full, deg * kDeg, kFine).r;
      const double ds =
          albedo_quadrature(simple, deg * kDeg, kCoarse).r - albedo_quadrature(simple, deg * kDeg, kFine).r;
      EXPECT_LT(std::fabs(df), sigma < sigma_neg ? 1e-11 : 2e-5) << sigma << " " << deg;
      EXPECT_LT(std::fabs(ds), 1e-11) << sigma << " " << deg;
    }
  }
}

TEST(OrenNayar, AlbedoMatchesAzimuthIntegratedReference) {
  // The 2-D quadrature of eval() against the 1-D reference with the azimuth done in closed form, where no clamping
  // occurs (σ below the turning point): 1e-9 absolute, both rules being converged to ~1e-15.
  const double sigma_neg = sigma_where_first_order_turns_negative();
  for (double sigma = 0.0; sigma < sigma_neg; sigma += 0.1) {
    const OrenNayar full(Rgb(1), sigma, false);
    const OrenNayarSimple simple(Rgb(1), sigma);
    for (double deg : {0.0, 20.0, 45.0, 70.0, 85.0, 89.0, 89.9}) {
      EXPECT_NEAR(albedo_quadrature(full, deg * kDeg).r, reference_albedo_full(sigma, deg * kDeg), 1e-9);
      EXPECT_NEAR(albedo_quadrature(simple, deg * kDeg).r, reference_albedo_simple(sigma, deg * kDeg), 1e-9);
    }
    // At normal incidence β = 0 and E = C1 exactly (A for the simplified model).
    EXPECT_NEAR(albedo_quadrature(full, 0.0).r, c1(sigma), 1e-12);
  }
}

struct Peak {
  double e = -1, sigma = 0, theta_deg = 0;
};

// Max of E over σ ∈ [0, 1.5] and θo ∈ [0°, 89.9°] by quadrature of eval(). The σ grid is fine (0.01) where the
// maxima lie (small σ) and coarse beyond; E grows with θo in every case measured, so the θo grid is dense near 90°.
template <class Make>
Peak albedo_peak(Make make) {
  std::vector<double> sigmas;
  for (int k = 0; k <= 40; ++k) sigmas.push_back(0.01 * k);
  for (int k = 5; k <= 15; ++k) sigmas.push_back(0.1 * k);
  Peak p;
  for (double sigma : sigmas) {
    const auto model = make(sigma);
    for (double deg : {0.0, 30.0, 60.0, 80.0, 85.0, 88.0, 89.0, 89.5, 89.9}) {
      const double e = albedo_quadrature(*model, deg * kDeg).r;
      if (e > p.e) p = {e, sigma, deg};
    }
  }
  return p;
}

void report(const std::string& key, const std::string& text) {
  std::cout << "[ measured ] " << text << "\n";
  ::testing::Test::RecordProperty(key, text);
}

TEST(OrenNayar, EnergyFullFirstOrder) {
  // Measured: the full first-order model (no interreflection) exceeds albedo 1 slightly for small σ at grazing
  // θo: max E = 1.003327 at σ = 0.13 rad, θo = 89.9° (E rises further towards 1.00365 as θo → 90°). For σ ≥ 0.2
  // rad it stays below 1 at every θo ≤ 89.9°, and at normal incidence E = C1 < 1. Survey section 6's claim that the
  // model conserves energy is therefore only approximately true; the bound below documents it.
  const Peak p = albedo_peak([](double s) { return std::make_unique<OrenNayar>(Rgb(1), s, false); });
  report("energy_full",
         fmt("full first-order: max E = %.6f at sigma = %.2f rad, theta_o = %.1f deg", p.e, p.sigma, p.theta_deg));
  // The peak is in the unclamped range, where the model's albedo matches the independent 1-D reference to 1e-9
  // (AlbedoMatchesAzimuthIntegratedReference); the figure is asserted against that reference to 2e-6 (its 7
  // significant digits), and the location exactly (grid points).
  EXPECT_NEAR(p.e, reference_albedo_full(0.13, 89.9 * kDeg), 1e-9);
  EXPECT_NEAR(p.e, 1.003327, 2e-6);
  EXPECT_DOUBLE_EQ(p.sigma, 0.13);
  EXPECT_DOUBLE_EQ(p.theta_deg, 89.9);
  // Where it conserves energy: σ ≥ 0.2 rad over all θo ≤ 89.9° (margin: the largest E there, 0.99983 at σ = 0.2,
  // is 1.7e-4 below 1, far above the quadrature error).
  for (double sigma = 0.2; sigma <= 1.5001; sigma += 0.1) {
    const OrenNayar m(Rgb(1), sigma, false);
    for (double deg : {0.0, 45.0, 80.0, 89.0, 89.9}) EXPECT_LT(albedo_quadrature(m, deg * kDeg).r, 1.0);
  }
}

TEST(OrenNayar, EnergyFullWithInterreflection) {
  // The two-bounce term adds 0.17 σ²/(σ²+0.13) at every θo (see InterreflectionTerm), so where the first-order albedo
  // is near 1 at grazing the sum exceeds 1. Measured: max E = 1.049963 at σ = 0.30 rad, θo = 89.9°.
  const Peak p = albedo_peak([](double s) { return std::make_unique<OrenNayar>(Rgb(1), s, true); });
  report(
      "energy_full_interreflection",
      fmt("full + interreflection: max E = %.6f at sigma = %.2f rad, theta_o = %.1f deg", p.e, p.sigma, p.theta_deg));
  // Independent figure: the 1-D first-order reference plus the closed-form E2. Tolerance as above.
  EXPECT_NEAR(p.e, reference_albedo_full(0.30, 89.9 * kDeg) + 0.17 * ratio(0.30, 0.13), 1e-9);
  EXPECT_NEAR(p.e, 1.049963, 2e-6);
  EXPECT_DOUBLE_EQ(p.sigma, 0.30);
  EXPECT_DOUBLE_EQ(p.theta_deg, 89.9);
}

TEST(OrenNayar, EnergySimplified) {
  // The simplified model keeps the positive C2 part and drops the negative branch that balances it in the full
  // model, so it exceeds 1 at grazing angles. Measured: max E = 1.015100 at σ = 0.20 rad, θo = 89.9°.
  const Peak p = albedo_peak([](double s) { return std::make_unique<OrenNayarSimple>(Rgb(1), s); });
  report("energy_simple",
         fmt("simplified: max E = %.6f at sigma = %.2f rad, theta_o = %.1f deg", p.e, p.sigma, p.theta_deg));
  EXPECT_NEAR(p.e, reference_albedo_simple(0.20, 89.9 * kDeg), 1e-9);
  EXPECT_NEAR(p.e, 1.015100, 2e-6);
  EXPECT_DOUBLE_EQ(p.sigma, 0.20);
  EXPECT_DOUBLE_EQ(p.theta_deg, 89.9);
}

TEST(OrenNayar, FirstOrderBracketTurnsNegativeAndIsClamped) {
  // The paper's C2 fit makes the first-order bracket negative for forward scattering near the horizon once
  // B/C1 > π/6; the turning σ from that closed form:
  const double s = sigma_where_first_order_turns_negative();
  report("negative_first_order_sigma",
         fmt("first-order bracket can go negative (clamped to 0) for sigma > %.4f rad", s));
  // Sanity of the closed form against the transcribed formula: just below s the bracket stays positive in the worst
  // configuration sampled densely; just above it goes negative.
  double worst_below = 1e9, worst_above = 1e9;
  for (double a = 80; a < 90; a += 0.01) {
    for (double b = 80; b <= a; b += 0.01) {
      worst_below = std::min(worst_below, paper_first_order(s - 0.01, a * kDeg, b * kDeg, kPi).value);
      worst_above = std::min(worst_above, paper_first_order(s + 0.01, a * kDeg, b * kDeg, kPi).value);
    }
  }
  EXPECT_GT(worst_below, 0);
  EXPECT_LT(worst_above, 0);
  // Where it is negative the model returns exactly 0 for the first order, and only the two-bounce term with it.
  const double sigma = 1.0, theta = 89.5 * kDeg;
  const Vec3 wo = direction(theta, 0.0), wi = direction(theta, kPi);
  ASSERT_LT(paper_first_order(sigma, theta, theta, kPi).value, 0);
  EXPECT_EQ(OrenNayar(Rgb(0.8), sigma, false).eval(wo, wi), Rgb(0.0));
  const double f2 = 0.64 * kInvPi * paper_interreflection(sigma, theta, theta, kPi);
  EXPECT_NEAR(OrenNayar(Rgb(0.8), sigma, true).eval(wo, wi).r, f2, 1e-14 * f2);
}

// ---- Sampling -------------------------------------------------------------------------------------------------------

TEST(OrenNayar, CosineSamplingMatchesQuadratureAlbedo) {
  struct Case {
    std::unique_ptr<Bxdf> model;
    double theta_deg;
  };
  std::vector<Case> cases;
  cases.push_back({std::make_unique<OrenNayar>(Rgb(0.9), 0.5, false), 60});
  cases.push_back({std::make_unique<OrenNayar>(Rgb(0.9), 0.3, true), 80});
  cases.push_back({std::make_unique<OrenNayar>(Rgb(1.0), 1.2, true), 45});
  cases.push_back({std::make_unique<OrenNayarSimple>(Rgb(0.9), 0.4), 75});
  for (const Case& c : cases) {
    const Vec3 wo = direction(c.theta_deg * kDeg, 0.7);
    Pcg32 rng(99);
    const int n = 1 << 17;
    double sum = 0, sum2 = 0;
    for (int k = 0; k < n; ++k) {
      const auto s = c.model->sample(wo, {rng.uniform(), rng.uniform()}, rng.uniform());
      double w = 0;
      if (s) {
        // The sample carries exactly what eval() and pdf() say (make_sample's contract).
        ASSERT_EQ(s->f, c.model->eval(wo, s->wi));
        ASSERT_EQ(s->pdf, c.model->pdf(wo, s->wi));
        ASSERT_EQ(s->pdf, s->wi.z * kInvPi);
        w = s->weight.r;
      }
      sum += w;
      sum2 += w * w;
    }
    const double mean = sum / n, se = std::sqrt((sum2 / n - mean * mean) / (n - 1));
    // The quadrature albedo is exact to < 1e-5 (far below the standard error, ~1e-3); 5 standard errors makes a false
    // failure a < 1e-6 event for a fixed seed's worth of luck, while a pdf off by a constant factor fails by far.
    const double e = albedo_quadrature(*c.model, c.theta_deg * kDeg).r;
    EXPECT_NEAR(mean, e, 5 * se) << c.model->describe() << " se=" << se;
  }
}

// ---- Stability -----------------------------------------------------------------------------------------------------

TEST(OrenNayar, FiniteAndNonNegativeEverywhere) {
  const double inf = std::numeric_limits<double>::infinity(), nan = std::numeric_limits<double>::quiet_NaN();
  const double g = std::sqrt(1.0 - 1e-14);  // sin θ for cos θ = 1e-7
  const std::vector<Vec3> dirs = {
      {0, 0, 1},                     // the normal: no azimuth
      {1e-200, 0, 1},                // tiny sin θ
      {g, 0, 1e-7},                  // grazing, cos θ = 1e-7
      {-g, 0, 1e-7},                 // grazing, opposite azimuth
      {0, g, 1e-7},                  // grazing, perpendicular azimuth
      {1, 0, 1e-310},                // subnormal cos θ: tan θ overflows
      {-1, 0, 5e-324},               // smallest subnormal
      {1, 0, 0},                     // on the horizon: reflects nothing
      {0.6, 0, -0.8},                // back-facing
      {0, 0, -1},                    // straight below
      {nan, 0, 1},                   // NaN components
      {0, 0, nan},     {inf, 0, 1},  // infinite components
      {0, 0, inf},     {0.6, 0, 0.8}, direction(89.9 * kDeg, 2.0),
  };
  for (double sigma : {0.0, 1e-300, 0.3, 1.0, kPiOver2, 10.0, 1e200}) {
    const OrenNayar full(Rgb(1), sigma, false), full_ir(Rgb(1), sigma, true);
    const OrenNayarSimple simple(Rgb(1), sigma);
    for (const Bxdf* m :
         {static_cast<const Bxdf*>(&full), static_cast<const Bxdf*>(&full_ir), static_cast<const Bxdf*>(&simple)}) {
      for (const Vec3& wo : dirs) {
        for (const Vec3& wi : dirs) {
          const Rgb f = m->eval(wo, wi);
          const double p = m->pdf(wo, wi);
          ASSERT_TRUE(f.is_finite() && f.min() >= 0) << m->describe();
          ASSERT_TRUE(std::isfinite(p) && p >= 0) << m->describe();
          // The contract: nothing is reflected unless both directions are finite and strictly above the horizon.
          if (!valid_reflection_pair(wo, wi)) {
            EXPECT_TRUE(f.is_black());
            EXPECT_EQ(p, 0.0);
          }
        }
        // Sampling, including the corners and the centre of the square (which maps to the normal).
        for (Point2 u : {Point2{0, 0}, Point2{0.5, 0.5}, Point2{0.999999999, 0.5}, Point2{0.3, 0.8}}) {
          const auto s = m->sample(wo, u, 0.5);
          if (!s) continue;
          EXPECT_TRUE(s->f.is_finite() && s->weight.is_finite() && std::isfinite(s->pdf) && s->pdf > 0);
          EXPECT_GE(s->weight.min(), 0);
        }
      }
    }
  }
  // Grazing pairs with cos θ = 1e-7 are large but finite (f ~ 0.45 σ²/(σ²+0.09)/π · 1e7).
  const OrenNayar full(Rgb(1), 0.5, true);
  const double f = full.eval(Vec3{g, 0, 1e-7}, Vec3{g, 0, 1e-7}).r;
  EXPECT_GT(f, 1e5);
  EXPECT_LT(f, 1e7);
}

TEST(OrenNayar, Describe) {
  EXPECT_EQ(OrenNayar(Rgb(0.8), 0.5, true).describe(), "oren-nayar(albedo=0.8, sigma=0.5, interreflection=on)");
  EXPECT_EQ(OrenNayar(Rgb(0.8, 0.5, 0.2), 0.25, false).describe(),
            "oren-nayar(albedo=0.8,0.5,0.2, sigma=0.25, interreflection=off)");
  EXPECT_EQ(OrenNayarSimple(Rgb(0.8), 0.3).describe(), "oren-nayar-simple(albedo=0.8, sigma=0.3)");
}

}  // namespace
}  // namespace kiln::brdf
