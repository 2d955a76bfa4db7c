#include "bakers/brdf/microfacet_distribution.h"

#include <algorithm>
#include <cfloat>
#include <cmath>

#include "bakers/brdf/beckmann_visible.h"
#include "bakers/math/constants.h"

namespace kiln::brdf {

MicrofacetDistribution::MicrofacetDistribution(Distribution kind, double alpha_x, double alpha_y)
    : kind_(kind), alpha_x_(alpha_x), alpha_y_(alpha_y) {
  if (kind_ == Distribution::schlick_beckmann) alpha_x_ = alpha_y_ = std::sqrt(alpha_x * alpha_y);
}

double MicrofacetDistribution::D_beckmann(const Vec3& wh) const {
  // χ⁺: facets at or below the horizon do not exist (and cos⁴θ_h = 0 would divide by zero).
  if (!(wh.z > 0)) return 0.0;
  const double cos2 = wh.z * wh.z;
  // tan²θ_h (cos²φ/α_x² + sin²φ/α_y²), written with the components so that no azimuth is needed at the normal.
  const double e = ((wh.x / alpha_x_) * (wh.x / alpha_x_) + (wh.y / alpha_y_) * (wh.y / alpha_y_)) / cos2;
  // Far in the tail exp(-e) underflows while 1/cos⁴ may overflow: the product is 0 to double precision.
  if (e > 700.0) return 0.0;
  return std::exp(-e) / (kPi * alpha_x_ * alpha_y_ * cos2 * cos2);
}

double MicrofacetDistribution::D(const Vec3& wh) const {
  if (!(wh.z > 0)) return 0.0;  // χ⁺(wh·n)
  switch (kind_) {
    case Distribution::ggx: {
      // Walter et al. eq 33 multiplied through by cos⁴θ_h: 1 / (π α_x α_y ((x/α_x)² + (y/α_y)² + z²)²).
      // This form has no tan θ_h, so it stays finite at grazing facets and for α → 0.
      const double sx = wh.x / alpha_x_, sy = wh.y / alpha_y_;
      const double e = sx * sx + sy * sy + wh.z * wh.z;
      return 1.0 / (kPi * alpha_x_ * alpha_y_ * e * e);
    }
    case Distribution::beckmann:
      return D_beckmann(wh);
    case Distribution::schlick_beckmann: {
      // Schlick's rational Beckmann (survey eq 20) in t = n·h, m = α: D = m³x / (t (m x² − x² + m²)²), x = t + m − 1,
      // zero below t = 1 − m. Like the survey's eq 13 it approximates the Beckmann D WITHOUT 1/π, so it is divided by
      // π here. So divided it is exactly normalised: with y = x², ∫ D t dω = m³ ∫_0^{m²} dy / (m² − (1 − m) y)² = 1
      // (tests/brdf/microfacet_test.cpp checks it). Its tail is heavier than Beckmann's, though, and it has no Smith
      // Λ of its own: paired with Beckmann's Λ its visible normals integrate to more than 1 at grazing angles (an
      // energy gain that tests/brdf/microfacet_test.cpp measures).
      const double m = alpha_x_;
      const double t = wh.z;
      const double x = t + m - 1.0;
      if (x <= 0.0) return 0.0;  // outside the approximation's support [1 − m, 1]
      const double q = m * x * x - x * x + m * m;
      return m * m * m * x / (t * q * q) * kInvPi;
    }
  }
  return 0.0;
}

double MicrofacetDistribution::Lambda(const Vec3& w) const {
  const double cos2 = w.z * w.z;
  const double sin2 = std::fmax(0.0, 1.0 - cos2);
  // At the normal nothing is masked (tan θ = 0); a horizontal or NaN direction is handled by the callers, which never
  // ask for it (the contract returns zero before), but answer "fully masked" rather than divide by zero.
  if (sin2 == 0.0) return 0.0;
  if (!(cos2 > 0)) return INFINITY;
  // Projected roughness along the azimuth of w (Heitz 2014, eq 80): α² = cos²φ α_x² + sin²φ α_y².
  const double alpha2 = (w.x * w.x * alpha_x_ * alpha_x_ + w.y * w.y * alpha_y_ * alpha_y_) / sin2;
  const double tan2 = sin2 / cos2;
  if (kind_ == Distribution::ggx) {
    // Λ = (−1 + sqrt(1 + α² tan²θ)) / 2, Walter et al. eq 34 rearranged.
    return 0.5 * (std::sqrt(1.0 + alpha2 * tan2) - 1.0);
  }
  // Beckmann (Walter et al. eq 27, exact): a = 1 / (α tan θ), Λ = (erf(a) − 1)/2 + exp(−a²) / (2 a sqrt(π)).
  const double a = 1.0 / std::sqrt(alpha2 * tan2);
  // For large a both terms cancel to below double precision: Λ is 0 (erf(a) = 1 and exp(−a²) underflows past a ≈ 27).
  if (a > 26.0) return 0.0;
  // erf(a) − 1 written as −erfc(a), which keeps its relative precision where Λ is small.
  return -0.5 * std::erfc(a) + std::exp(-a * a) / (2.0 * a * std::sqrt(kPi));
}

double MicrofacetDistribution::D_visible(const Vec3& w, const Vec3& wh) const {
  if (!(w.z > 0)) return 0.0;
  const double w_dot_h = dot(w, wh);
  if (!(w_dot_h > 0)) return 0.0;  // back-facing microfacets are not visible from w
  return G1(w) * w_dot_h * D(wh) / w.z;
}

Vec3 MicrofacetDistribution::sample_wh(const Vec3& wo, Point2 u) const {
  if (kind_ == Distribution::ggx) {
    // Heitz 2018, "Sampling the GGX Distribution of Visible Normals": stretch wo to the configuration of a
    // hemisphere of unit roughness, sample the projected visible area there, and unstretch.
    const Vec3 vh = normalize(Vec3{alpha_x_ * wo.x, alpha_y_ * wo.y, wo.z});
    const double len2 = vh.x * vh.x + vh.y * vh.y;
    // wo along the normal: the orthonormal basis around vh is arbitrary; pick x.
    const Vec3 t1 = len2 > 0 ? Vec3{-vh.y, vh.x, 0.0} / std::sqrt(len2) : Vec3{1.0, 0.0, 0.0};
    const Vec3 t2 = cross(vh, t1);
    const double r = std::sqrt(u.x);
    const double phi = 2.0 * kPi * u.y;
    const double p1 = r * std::cos(phi);
    double p2 = r * std::sin(phi);
    const double s = 0.5 * (1.0 + vh.z);
    p2 = (1.0 - s) * std::sqrt(std::fmax(0.0, 1.0 - p1 * p1)) + s * p2;
    const Vec3 nh = t1 * p1 + t2 * p2 + vh * std::sqrt(std::fmax(0.0, 1.0 - p1 * p1 - p2 * p2));
    return normalize(Vec3{alpha_x_ * nh.x, alpha_y_ * nh.y, std::fmax(0.0, nh.z)});
  }
  // Seen from the normal the visible normals are D(wh) cos θ_h; the projected sampler draws them with the same map
  // as before visible-normal sampling existed, so the environment bake (which samples from v = n) keeps its bytes.
  if (kind_ == Distribution::schlick_beckmann || (wo.x == 0.0 && wo.y == 0.0)) return sample_wh_projected(u);
  // Beckmann (Heitz & d'Eon 2014, section 4): stretch wo to unit roughness, sample the visible slopes there in the
  // frame of wo's azimuth, rotate them back, unstretch, and take the normal of that slope.
  const Vec3 ws = normalize(Vec3{alpha_x_ * wo.x, alpha_y_ * wo.y, wo.z});
  const double len = std::hypot(ws.x, ws.y);
  // len > 0: wo is off the normal and the widths are positive.
  const double cos_phi = ws.x / len, sin_phi = ws.y / len;
  const Point2 s = sample_beckmann_visible_slope(ws.z, u);
  const double sx = alpha_x_ * (cos_phi * s.x - sin_phi * s.y);
  const double sy = alpha_y_ * (sin_phi * s.x + cos_phi * s.y);
  return normalize(Vec3{-sx, -sy, 1.0});
}

double MicrofacetDistribution::pdf_wh(const Vec3& wo, const Vec3& wh) const {
  if (kind_ != Distribution::schlick_beckmann) return D_visible(wo, wh);
  if (!(wh.z > 0)) return 0.0;
  return D(wh) * wh.z;
}

double MicrofacetDistribution::slope_radius(double u) const {
  if (kind_ == Distribution::ggx) {
    // GGX slopes of unit roughness: P(r) = r² / (1 + r²), so r² = ξ / (1 − ξ); 1 − ξ > 0 since u ∈ [0, 1).
    return std::sqrt(u / (1.0 - u));
  }
  // Beckmann slopes are Gaussian: P22(x̃, ỹ) ∝ exp(−x̃²/α_x² − ỹ²/α_y²), the radius sampled as in Box–Muller.
  // u = 0 gives the radius 0 (the normal itself); 1 − u > 0 since u ∈ [0, 1).
  return std::sqrt(-std::log1p(-u));
}

double MicrofacetDistribution::rational_cos_theta(double u) const {
  // Inverting the CDF of D(t) t in x = t − (1 − m), measured from the lower end of the support:
  // P(x) = m³ / (1 − m) [1 / (m² − (1 − m) x²) − 1 / m²] = ξ  gives  x² = m² ξ / (m + ξ (1 − m)).
  const double m = alpha_x_;
  const double x = m * std::sqrt(u / (m + u * (1.0 - m)));
  return std::fmin(1.0, x + 1.0 - m);
}

Vec3 MicrofacetDistribution::sample_wh_projected(Point2 u) const {
  const double phi = 2.0 * kPi * u.y;
  if (kind_ == Distribution::schlick_beckmann) {
    const double cos_theta = rational_cos_theta(u.x);
    const double sin_theta = std::sqrt(std::fmax(0.0, 1.0 - cos_theta * cos_theta));
    return {sin_theta * std::cos(phi), sin_theta * std::sin(phi), cos_theta};
  }
  // Both D's are stretched isotropic slope distributions: draw the slope radius r of unit roughness, stretch by the
  // widths, and take the normal (−x̃, −ỹ, 1) normalised; D is even in the slope, so the sign is immaterial.
  const double r = slope_radius(u.x);
  return normalize(Vec3{-alpha_x_ * r * std::cos(phi), -alpha_y_ * r * std::sin(phi), 1.0});
}

namespace {

// ψ ∈ [0, π] with density clamp(1 + c cos ψ, 0, 2) / π (c ≥ 0), by inverting its CDF at t ∈ [0, 1]. For c ≤ 1 the
// CDF is (ψ + c sin ψ)/π (Kepler's equation, solved by safeguarded Newton); for c > 1 the density is 2/π up to
// ψ1 = acos(1/c), 0 beyond π − ψ1, and 1 + c cos ψ between.
double sample_v_cavity_offset(double c, double t) {
  const double target = t * kPi;
  double lo = 0.0, hi = kPi, base = 0.0;
  if (c > 1.0) {
    const double psi1 = std::acos(1.0 / c);
    if (target <= 2.0 * psi1) return 0.5 * target;
    lo = psi1;
    hi = kPi - psi1;
    base = 2.0 * psi1 - (psi1 + c * std::sin(psi1));  // the CDF·π is continuous at ψ1, where it is 2 ψ1
  }
  const auto cdf = [&](double psi) { return base + psi + c * std::sin(psi); };
  const double c_lo = cdf(lo), c_hi = cdf(hi);
  // The secant of the bracket as a start; Newton from there, bisecting when a step leaves the bracket.
  double psi = c_hi > c_lo ? std::clamp(lo + (hi - lo) * (target - c_lo) / (c_hi - c_lo), lo, hi) : lo;
  for (int it = 0; it < 100; ++it) {
    const double f = cdf(psi) - target;
    // Converged in probability (a few ulps of π); near ψ = π the density vanishes for c = 1 and ψ itself is
    // ill-conditioned, but every ψ there has the right probability.
    if (std::fabs(f) <= 8.0 * DBL_EPSILON * (1.0 + c)) break;
    (f < 0.0 ? lo : hi) = psi;
    const double density = 1.0 + c * std::cos(psi);
    double next = density > 0.0 ? psi - f / density : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (next == psi) break;
    psi = next;
  }
  return psi;
}

// The signed offset ψ ∈ [−π, π] from u ∈ [0, 1), monotone and continuous in u (stratification carries over).
double sample_v_cavity_azimuth(double c, double u) {
  return u < 0.5 ? -sample_v_cavity_offset(c, 1.0 - 2.0 * u) : sample_v_cavity_offset(c, 2.0 * u - 1.0);
}

}  // namespace

Vec3 MicrofacetDistribution::sample_wh_v_cavity(const Vec3& wo, Point2 u) const {
  // Heitz & d'Eon 2014, section 5.1: draw a facet of the V from D cos θ_h, then keep it or take its mirror image in
  // proportion to their projected areas a = max(0, wo·wh) and b = max(0, wo·wh'). Done directly, that choice needs
  // a third random number, which stratified estimators leave unstratified (and the two facets' weights differ
  // through F). Instead the azimuth is drawn from its density given the polar angle or slope radius, which is
  // uniform (D cos θ_h is isotropic in the unit-roughness slope plane) times 2a / (a + b): with
  // wo·wh ∝ 1 + c cos ψ (ψ the azimuth of the facet from the one facing wo most), a + b = 2 where both faces are
  // visible, so the density is clamp(1 + c cos ψ, 0, 2) / (2π), inverted in closed form up to Kepler's equation.
  if (kind_ == Distribution::schlick_beckmann) {
    const double cos_theta = rational_cos_theta(u.x);
    const double sin_theta = std::sqrt(std::fmax(0.0, 1.0 - cos_theta * cos_theta));
    const double sin_o = std::hypot(wo.x, wo.y);
    // wo·wh = cos θ_o cos θ_h + sin θ_o sin θ_h cos(φ − φ_o): c = tan θ_o tan θ_h (0 along the normal).
    const double c = sin_o > 0.0 && cos_theta > 0.0 ? (sin_o * sin_theta) / (wo.z * cos_theta) : 0.0;
    const double phi_o = sin_o > 0.0 ? std::atan2(wo.y, wo.x) : 0.0;
    const double phi = phi_o + sample_v_cavity_azimuth(c, u.y);
    return {sin_theta * std::cos(phi), sin_theta * std::sin(phi), cos_theta};
  }
  // GGX and Beckmann: wh ∝ (−α_x r cos φ', −α_y r sin φ', 1) with φ' uniform under D cos θ_h, so
  // wo·wh ∝ wo.z − r A cos(φ' − β) with A = |(α_x wo.x, α_y wo.y)| and β its angle: c = r A / wo.z, φ' = β + π + ψ.
  const double r = slope_radius(u.x);
  const double ax = alpha_x_ * wo.x, ay = alpha_y_ * wo.y;
  const double a_len = std::hypot(ax, ay);
  const double c = a_len > 0.0 && r > 0.0 ? r * a_len / wo.z : 0.0;
  const double beta = a_len > 0.0 ? std::atan2(ay, ax) : 0.0;
  const double phi = beta + kPi + sample_v_cavity_azimuth(c, u.y);
  return normalize(Vec3{-alpha_x_ * r * std::cos(phi), -alpha_y_ * r * std::sin(phi), 1.0});
}

double MicrofacetDistribution::pdf_wh_v_cavity(const Vec3& wo, const Vec3& wh) const {
  if (!(wo.z > 0) || !(wh.z > 0)) return 0.0;
  const double o_dot_h = dot(wo, wh);
  if (!(o_dot_h > 0)) return 0.0;  // back-facing facets are never picked
  // Drawn directly (kept with probability a / (a + b)) or as the mirror of its mirror image: 2 D cos θ_h a / (a + b).
  // When both facets face wo, a + b = 2 (n·wo)(n·wh); when only this one does, a + b = a.
  return D(wh) * std::fmin(o_dot_h, 2.0 * wh.z * wo.z) / wo.z;
}

}  // namespace kiln::brdf
