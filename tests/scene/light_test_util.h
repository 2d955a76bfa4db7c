// Test helpers for the light sources (header-only, shared by tests/scene/*light*_test.cpp and distribution_test): a
// χ² test of a direction sampler against a density (Mitsuba's check, in cells of (θ, φ) about an axis chosen to frame
// the light; Pearson's statistic with pooling is tests/support/chi2.h's pearson_chi2), and irradiance estimates with
// their standard error.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "bakers/math/constants.h"
#include "bakers/math/rng.h"
#include "bakers/scene/emissive_triangles.h"
#include "bakers/scene/lights.h"
#include "tests/support/chi2.h"
#include "tests/support/hemisphere.h"

namespace kiln::test {

// One sample of a direction sampler: the direction and the density it reported; nullopt for a failed sample.
struct DirectionDraw {
  Vec3 wi;
  double pdf = 0;
};
using DirectionSampler = std::function<std::optional<DirectionDraw>(Point2)>;

struct DirectionChi2Options {
  Vec3 axis{0, 0, 1};      // cells are (θ, φ) about this axis ...
  double theta_max = kPi;  // ... for θ ≤ theta_max; directions beyond join the failed samples' category
  int n_theta = 24, n_phi = 48;
  int64_t samples = 200000;
  uint64_t seed = 7;
  double significance = 0.01;  // family-wise
  int test_count = 1;          // Šidák correction over the family
  int max_depth = 9;           // adaptive refinement of cells crossed by the light's edge (a jump of the pdf)
  int presplit = 4;            // pieces per cell side integrated separately (see direction_chi2)
  // The light lies inside the cells and sample() does not fail: test the shape of the distribution only. Expected
  // cell counts are then scaled to the number of samples (∫ pdf over the cells is checked separately, with its own
  // tolerance), and any sample outside the cells or failed is a rejection. The quadrature of a density with a jump
  // along the light's outline is short by ~1e-5, which would otherwise show as ~1e-5·N "missing" failures.
  bool shape_only = false;
};

struct DirectionChi2Result {
  bool passed = false;
  double p_value = 0, threshold = 0;
  double pdf_integral = 0;  // ∫ pdf over the cells
  double pdf_integral_error = 0;
  int64_t failures = 0;
  int64_t pdf_mismatches = 0;  // samples whose reported pdf differs from pdf(wi) by more than 1e-6 relative
  std::string details;
};

// χ² of `sampler` against `pdf` (per solid angle): counts in cells against N ∫_cell pdf dω by adaptive
// Gauss–Legendre; failed samples and samples beyond theta_max form one category with expectation N (1 − ∫ pdf)
// (0 with shape_only).
// Also checks that every sample reports the density pdf() gives its direction (sample_li against pdf_li).
inline DirectionChi2Result direction_chi2(const DirectionSampler& sampler,
                                          const std::function<double(const Vec3&)>& pdf,
                                          const DirectionChi2Options& o) {
  DirectionChi2Result res;
  res.threshold = sidak_significance(o.significance, o.test_count);
  const Frame frame = Frame::from_normal(normalize(o.axis));
  const int n_cells = o.n_theta * o.n_phi;
  const double dtheta = o.theta_max / o.n_theta, dphi = 2.0 * kPi / o.n_phi;
  std::vector<double> observed(n_cells + 1, 0.0), expected(n_cells + 1, 0.0);
  Pcg32 rng(o.seed, 0x2545f4914f6cdd1dULL ^ o.seed);
  for (int64_t k = 0; k < o.samples; ++k) {
    const Point2 u{rng.uniform(), rng.uniform()};
    const auto s = sampler(u);
    if (!s) {
      ++res.failures;
      observed[n_cells] += 1;
      continue;
    }
    const double expect_pdf = pdf(s->wi);
    if (!(std::fabs(expect_pdf - s->pdf) <= 1e-6 * std::max(expect_pdf, s->pdf))) ++res.pdf_mismatches;
    const Vec3 w = frame.to_local(s->wi);
    const double theta = spherical_theta(w);
    if (theta > o.theta_max) {
      observed[n_cells] += 1;
      continue;
    }
    const int it = std::min(static_cast<int>(theta / dtheta), o.n_theta - 1);
    const int ip = std::min(static_cast<int>(spherical_phi(w) / dphi), o.n_phi - 1);
    observed[it * o.n_phi + ip] += 1;
  }
  const DirectionFunction local_pdf = [&](const Vec3& w) { return pdf(frame.from_local(w)); };
  for (int it = 0; it < o.n_theta; ++it) {
    for (int ip = 0; ip < o.n_phi; ++ip) {
      // Each cell is integrated as split × split pieces before the adaptive refinement starts, so that a sliver of
      // the light that falls between a whole cell's nodes (all zero: "converged") is still seen.
      double value = 0;
      for (int a = 0; a < o.presplit; ++a) {
        for (int b = 0; b < o.presplit; ++b) {
          const double t0 = (it + static_cast<double>(a) / o.presplit) * dtheta;
          const double p0 = (ip + static_cast<double>(b) / o.presplit) * dphi;
          const CellIntegral ci = integrate_cell(local_pdf, t0, t0 + dtheta / o.presplit, p0, p0 + dphi / o.presplit,
                                                 1e-5, 1e-12, 3, o.max_depth);
          value += ci.value;
          res.pdf_integral_error += ci.error;
        }
      }
      expected[it * o.n_phi + ip] = value * static_cast<double>(o.samples);
      res.pdf_integral += value;
    }
  }
  if (o.shape_only) {
    for (int c = 0; c < n_cells; ++c) expected[c] *= 1.0 / res.pdf_integral;
    expected[n_cells] = 0;
  } else {
    expected[n_cells] = std::max(0.0, 1.0 - res.pdf_integral) * static_cast<double>(o.samples);
  }
  const PearsonResult p = pearson_chi2(observed, expected, 5.0, 6, [&](size_t i) {
    if (i == static_cast<size_t>(n_cells)) return std::string("failed or outside the cells");
    return "cell theta " + std::to_string(i / o.n_phi) + "/" + std::to_string(o.n_theta) + ", phi " +
           std::to_string(i % o.n_phi) + "/" + std::to_string(o.n_phi);
  });
  res.p_value = p.p_value;
  res.passed = p.p_value > res.threshold && res.pdf_mismatches == 0;
  std::ostringstream out;
  out << "chi2 = " << p.statistic << ", dof = " << p.dof << ", p = " << p.p_value << " (reject below " << res.threshold
      << "), pdf integral over the cells " << res.pdf_integral << " +- " << res.pdf_integral_error << ", failed "
      << res.failures << " / " << o.samples << ", pdf mismatches " << res.pdf_mismatches << "\n"
      << p.worst;
  res.details = out.str();
  return res;
}

// Adapts a light's sample_li / pdf_li at (p, n) to the χ² helper.
inline DirectionSampler light_sampler_at(const scene::LightSource& light, const Vec3& p, const Vec3& n) {
  return [&light, p, n](Point2 u) -> std::optional<DirectionDraw> {
    const auto s = light.sample_li(p, n, u);
    if (!s) return std::nullopt;
    return DirectionDraw{s->wi, s->pdf};
  };
}

// Mean and standard error of the irradiance estimator Li cos θ / pdf at (p, n) over N samples.
struct Estimate {
  double mean = 0, standard_error = 0;
  bool all_finite = true;
};
inline Estimate estimate_irradiance(const scene::LightSource& light, const Vec3& p, const Vec3& n, int64_t samples,
                                    uint64_t seed, int channel = 0) {
  Pcg32 rng(seed, 0xda942042e4dd58b5ULL);
  double sum = 0, sum2 = 0;
  Estimate e;
  for (int64_t k = 0; k < samples; ++k) {
    const auto s = light.sample_li(p, n, {rng.uniform(), rng.uniform()});
    double v = 0;
    if (s) {
      if (!is_finite(s->wi) || !s->Li.is_finite() || !std::isfinite(s->pdf)) e.all_finite = false;
      v = s->irradiance(dot(s->wi, n))[channel];
    }
    if (!std::isfinite(v)) e.all_finite = false;
    sum += v;
    sum2 += v * v;
  }
  const double n_s = static_cast<double>(samples);
  e.mean = sum / n_s;
  e.standard_error = std::sqrt(std::fmax(0.0, sum2 / n_s - e.mean * e.mean) / (n_s - 1.0));
  return e;
}

// The nearest emissive triangle the ray p + t·w (t > 0) hits (Möller–Trumbore), as the tracer would report it:
// LightHit::triangle = −1 when it misses them all.
inline scene::LightHit intersect_triangles(const scene::EmissiveTriangles& tris, const Vec3& p, const Vec3& w) {
  scene::LightHit best;
  for (int i = 0; i < tris.size(); ++i) {
    const auto& t = tris.triangle(i);
    const Vec3 e1 = t.p1 - t.p0, e2 = t.p2 - t.p0, q = cross(w, e2);
    const double det = dot(e1, q);
    if (det == 0) continue;  // the ray is parallel to the triangle's plane
    const Vec3 s = p - t.p0, r = cross(s, e1);
    const double b1 = dot(s, q) / det, b2 = dot(w, r) / det, tt = dot(e2, r) / det;
    if (b1 < 0 || b2 < 0 || b1 + b2 > 1 || !(tt > 0) || tt >= best.distance) continue;
    best.triangle = i;
    best.distance = tt;
    best.point = p + w * tt;
    best.normal = normalize(cross(e1, e2));
  }
  return best;
}

}  // namespace kiln::test
