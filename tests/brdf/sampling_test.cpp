// sample() against pdf() and eval() for every catalogue entry (tests/support/model_catalog.h):
// - a chi-square goodness-of-fit test of the sampled directions against the density pdf() claims, with failed samples
//   as one more category (expected N (1 − ∫ pdf)), at several outgoing directions;
// - ∫ pdf ≤ 1 over the hemisphere;
// - every successful sample reports f = eval(wo, wi), pdf = pdf(wo, wi) and weight = f cos θi / pdf.
// The harness itself (incomplete gamma, Šidák, the power of the test) is checked first against closed forms.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "bakers/math/constants.h"
#include "bakers/math/rng.h"
#include "tests/support/chi2.h"
#include "tests/support/hemisphere.h"
#include "tests/support/model_catalog.h"
#include "tests/support/tolerance.h"

namespace kiln::test {
namespace {

// ---------------------------------------------------------------------------------------------------------------
// The harness.

// Closed forms: Q(1, x) = e^−x; Q(n, x) = e^−x Σ_{k<n} x^k / k! for integer n; Q(1/2, x) = erfc(√x).
// Tolerance 1e-12 relative: both sides are evaluated to about 1e-15 (the series and the fraction stop at a relative
// increment of 1e-15; the sums here have at most ~100 positive terms); the margin covers lgamma's few-ulp error
// amplified by a ≤ 100 in the exponent of the prefactor.
TEST(Chi2Harness, IncompleteGammaMatchesClosedForms) {
  for (double x : {1e-3, 0.1, 0.5, 1.0, 2.0, 5.0, 20.0, 100.0}) {
    EXPECT_TRUE(close(gamma_q(1.0, x), std::exp(-x), 1e-12)) << "x = " << x;
    EXPECT_TRUE(close(gamma_q(0.5, x), std::erfc(std::sqrt(x)), 1e-12)) << "x = " << x;
    for (int n : {2, 5, 30}) {
      double term = 1.0, sum = 0.0;
      for (int k = 0; k < n; ++k) {
        sum += term;
        term *= x / (k + 1);
      }
      const double q = std::exp(-x) * sum;
      if (q < 1e-280) continue;  // e^−x underflows the closed form's precision
      EXPECT_TRUE(close(gamma_q(n, x), q, 1e-12)) << "n = " << n << ", x = " << x;
      EXPECT_TRUE(close(gamma_p(n, x), 1.0 - q, 1e-12, 1e-15)) << "n = " << n << ", x = " << x;
    }
  }
  // χ² with 2 degrees of freedom is exponential: p = e^{−s/2}.
  for (double s : {0.01, 1.0, 10.0, 60.0}) EXPECT_TRUE(close(chi2_p_value(s, 2), std::exp(-0.5 * s), 1e-12));
}

// The dof of the real tests are in the thousands; there the Wilson–Hilferty cube-root normal approximation is accurate
// to O(1/dof) ≈ 1e-4 in p, so it is an independent check at tolerance 2e-3 (and P + Q = 1 to rounding).
TEST(Chi2Harness, LargeDofMatchesWilsonHilferty) {
  for (double k : {1000.0, 8000.0}) {
    for (double z : {-2.0, 0.0, 1.0, 3.0}) {
      // Wilson–Hilferty: (s/k)^(1/3) ≈ normal with mean 1 − 2/(9k) and variance 2/(9k).
      const double m = 1.0 - 2.0 / (9.0 * k), sd = std::sqrt(2.0 / (9.0 * k));
      const double s = k * std::pow(m + z * sd, 3.0);
      const double p_normal = 0.5 * std::erfc(z / std::sqrt(2.0));
      EXPECT_NEAR(chi2_p_value(s, k), p_normal, 2e-3) << "dof " << k << ", z " << z;
      EXPECT_NEAR(gamma_p(0.5 * k, 0.5 * s) + gamma_q(0.5 * k, 0.5 * s), 1.0, 1e-13);
    }
  }
}

TEST(Chi2Harness, SidakCorrection) {
  EXPECT_DOUBLE_EQ(sidak_significance(0.01, 1), 0.01);
  for (int m : {2, 10, 400}) {
    const double s = sidak_significance(0.01, m);
    // (1 − s)^m = 1 − α to rounding (a few ulps of the log/exp round trip).
    EXPECT_NEAR(std::pow(1.0 - s, m), 0.99, 1e-14) << m;
  }
}

// Toy models with known sampling, to show that the harness accepts a correct sampler and rejects wrong ones.
class ToyBxdf : public brdf::Bxdf {
 public:
  enum class Kind { uniform, cosine_claims_cos11, drops_one_percent, cosine_claims_uniform };
  explicit ToyBxdf(Kind k) : kind_(k) {}
  Rgb eval(const Vec3&, const Vec3& wi) const override { return wi.z > 0 ? Rgb(kInvPi) : Rgb{}; }
  std::optional<brdf::BsdfSample> sample(const Vec3& wo, Point2 u, double uc) const override {
    if (kind_ == Kind::drops_one_percent && uc < 0.01) return std::nullopt;
    const Vec3 wi = kind_ == Kind::uniform ? sample_uniform_hemisphere(u) : sample_cosine_hemisphere(u);
    return brdf::make_sample(wi, eval(wo, wi), pdf(wo, wi));
  }
  double pdf(const Vec3&, const Vec3& wi) const override {
    if (!(wi.z > 0)) return 0.0;
    switch (kind_) {
      case Kind::uniform:
      case Kind::cosine_claims_uniform:
        return kInv2Pi;
      case Kind::cosine_claims_cos11:
        return 2.1 * std::pow(wi.z, 1.1) * kInv2Pi;  // normalised cos^1.1 lobe
      case Kind::drops_one_percent:
        return wi.z * kInvPi;
    }
    return 0.0;
  }
  std::string describe() const override { return "toy"; }

 private:
  Kind kind_;
};

TEST(Chi2Harness, AcceptsCorrectAndRejectsWrongSamplers) {
  Chi2Options o;
  o.test_count = 4;
  const Vec3 wo = spherical_direction(0.5, 0.2);
  const Chi2Result good = chi2_test(ToyBxdf(ToyBxdf::Kind::uniform), wo, o);
  EXPECT_TRUE(good.passed) << good.details;
  // Uniform pdf over the hemisphere integrates to 1 (smooth integrand: the adaptive rule is accurate to ~1e-12).
  EXPECT_NEAR(good.pdf_integral, 1.0, 1e-9);
  // cos θ against a claimed cos^1.1: a 5% slope error. Its χ² distance is ≈ 2.5e-3, i.e. an expected excess of ~750
  // over dof ≈ 8000 (σ ≈ 130): the test must see it.
  const Chi2Result tilt = chi2_test(ToyBxdf(ToyBxdf::Kind::cosine_claims_cos11), wo, o);
  EXPECT_FALSE(tilt.passed) << tilt.details;
  EXPECT_FALSE(chi2_test(ToyBxdf(ToyBxdf::Kind::cosine_claims_uniform), wo, o).passed);
  // 1% of samples fail while pdf() claims a unit integral: the failure category catches it.
  const Chi2Result drop = chi2_test(ToyBxdf(ToyBxdf::Kind::drops_one_percent), wo, o);
  EXPECT_FALSE(drop.passed) << drop.details;
  EXPECT_NEAR(drop.failed_fraction, 0.01, 5 * std::sqrt(0.01 * 0.99 / o.samples));
}

// The rejection sampler of the cosine lobe that the lightmap transport draws with its generator
// (sample_cosine_hemisphere(rng), 32 random bits per coordinate), through the same χ² harness as the models: a
// lobe whose sample() runs it on a generator seeded from the harness's numbers.
class RejectionCosine : public brdf::Bxdf {
 public:
  Rgb eval(const Vec3&, const Vec3& wi) const override { return wi.z > 0 ? Rgb(kInvPi) : Rgb{}; }
  std::optional<brdf::BsdfSample> sample(const Vec3& wo, Point2 u, double) const override {
    Pcg32 rng(static_cast<uint64_t>(u.x * 0x1.0p53), static_cast<uint64_t>(u.y * 0x1.0p53));
    const Vec3 wi = sample_cosine_hemisphere(rng);
    return brdf::make_sample(wi, eval(wo, wi), pdf(wo, wi));
  }
  double pdf(const Vec3&, const Vec3& wi) const override { return wi.z > 0 ? wi.z * kInvPi : 0.0; }
  std::string describe() const override { return "rejection cosine"; }
};

TEST(Chi2Harness, RejectionCosineSamplerMatchesItsDensity) {
  Chi2Options o;
  o.test_count = 1;
  const Chi2Result r = chi2_test(RejectionCosine(), spherical_direction(0.3, 0.1), o);
  EXPECT_TRUE(r.passed) << r.details;
  EXPECT_EQ(r.invalid, 0);
  EXPECT_EQ(r.failures, 0);
}

// ---------------------------------------------------------------------------------------------------------------
// The catalogue.

struct SamplingCase {
  const CatalogEntry* entry;
  double theta_deg, phi_deg;
  std::string name;
};

std::string angle_name(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  std::string s(buf);
  for (char& c : s)
    if (c == '.') c = '_';
  return s;
}

bool is_microfacet(brdf::Model m) {
  return m == brdf::Model::ggx || m == brdf::Model::beckmann || m == brdf::Model::cook_torrance;
}

std::vector<SamplingCase> make_cases() {
  // θo = 0 exactly (wo on the normal), 0.01° (the normal perturbed), 30°, 60° and 85° (grazing), at azimuths away
  // from the axes so that an isotropic model's rotation invariance is exercised; anisotropic models also along and
  // across the tangent and at 45°.
  struct Angle {
    double theta, phi;
  };
  // Entries that differ from an earlier one only in terms the sampling does not follow (sampling_variant) run at two
  // of these angles (three if anisotropic): enough to catch a term leaking into sample() or pdf(), within the budget.
  const std::vector<Angle> iso{{0, 0}, {0.01, 37}, {30, 0}, {60, 135}, {85, 250}};
  const std::vector<Angle> aniso{{60, 0}, {60, 90}, {85, 45}};
  const std::vector<Angle> variant{{30, 0}, {85, 250}};
  // Grazing wo, where the visible-normal samplers differ most from D cos θ_h and where their inversions (Beckmann's
  // Newton iteration near cot θ, the V-cavity's choice of facet) are hardest: every microfacet entry, at 89° and
  // 89.9° (cos θo = 1.7e-3), the anisotropic ones also across the tangent.
  const std::vector<Angle> grazing{{89, 300}, {89.9, 10}};
  std::vector<SamplingCase> out;
  for (const CatalogEntry& e : model_catalog()) {
    std::vector<Angle> angles = e.sampling_variant ? variant : iso;
    if (e.anisotropic && e.sampling_variant) angles.push_back({60, 90});
    if (e.anisotropic && !e.sampling_variant) angles.insert(angles.end(), aniso.begin(), aniso.end());
    if (is_microfacet(e.spec.model)) {
      angles.insert(angles.end(), grazing.begin(), grazing.end());
      if (e.anisotropic) angles.push_back({89.9, 90});
    }
    for (const Angle& a : angles)
      out.push_back({&e, a.theta, a.phi, e.name + "_t" + angle_name(a.theta) + "_p" + angle_name(a.phi)});
  }
  return out;
}

const std::vector<SamplingCase>& cases() {
  static const std::vector<SamplingCase> c = make_cases();
  return c;
}

uint64_t fnv1a(const std::string& s) {
  uint64_t h = 1469598103934665603ULL;
  for (unsigned char ch : s) h = (h ^ ch) * 1099511628211ULL;
  return h;
}

Vec3 wo_of(const SamplingCase& c) { return spherical_direction(c.theta_deg * kPi / 180.0, c.phi_deg * kPi / 180.0); }

// GoogleTest prints parameters in failure messages: the case name, not the bytes.
void PrintTo(const SamplingCase& c, std::ostream* os) { *os << c.name; }

class SamplingTest : public ::testing::TestWithParam<SamplingCase> {};

TEST_P(SamplingTest, ChiSquareSampleMatchesPdf) {
  const SamplingCase& c = GetParam();
  const auto bxdf = c.entry->make();
  Chi2Options o;
  o.seed = fnv1a(c.name);
  o.test_count = static_cast<int>(cases().size());  // Šidák over every χ² test of this file's family
  // Resolution and sample count (runtime budget: ~320 cases). Lobes of α ≥ 0.3 are ≥ 0.3 rad wide: 2.8° × 5.6° cells
  // resolve them, and fewer cells mean fewer degrees of freedom, i.e. more power against smooth discrepancies for the
  // same N (about 50 samples per cell). Lobes of α = 0.05 are ~0.1 rad wide in wi (≈ 2α): 1.4° × 2.8° cells keep
  // four or more cells across them (about 18 samples per cell).
  o.n_theta = 32;
  o.n_phi = 64;
  o.samples = 100000;
  if (c.entry->sharp) {
    o.n_theta = 64;
    o.n_phi = 128;
    o.samples = 150000;
  }
  // At θo = 89.9° the lobes are squeezed against the horizon, and the pdf's kinks (the V-cavity's, the visible
  // normals' cut) cross many cells: the adaptive rule needs two more levels to bound its error below 1e-4.
  if (c.theta_deg >= 89.0) o.integration_max_depth = 8;
  const Chi2Result r = chi2_test(*bxdf, wo_of(c), o);
  std::cout << "[chi2] " << c.name << ": p = " << r.p_value << ", pdf integral = " << r.pdf_integral << " +- "
            << r.pdf_integral_error << ", failed fraction = " << r.failed_fraction << "\n";
  EXPECT_TRUE(r.passed) << r.details;
  EXPECT_EQ(r.invalid, 0) << "samples with wi below the horizon, non-finite or not unit length\n" << r.details;
  // ∫ pdf ≤ 1 up to the quadrature's own error bound (plus rounding of ~10^4 cell sums, far below 1e-9).
  EXPECT_LE(r.pdf_integral, 1.0 + r.pdf_integral_error + 1e-9) << r.details;
  // The expected counts must be accurate far below the statistical noise: a total error δ in probability moves
  // N δ ≤ 15 samples between cells (N ≤ 1.5e5), against a noise of √N ≈ 390 in total and ≈ 4 per cell.
  EXPECT_LT(r.pdf_integral_error, 1e-4) << "pdf() has features the adaptive quadrature does not resolve\n" << r.details;
}

// Relative agreement of quantities computed along two code paths in double precision from the same wi (sample()
// derives f and pdf from its half vector, eval()/pdf() recompute it from wo + wi, which rounds differently): the
// formulas are well conditioned at these angles (condition numbers far below 1e6), so 1e-9 leaves ample room while
// any formula mismatch shows at O(1e-2) or more. The absolute floor 1e-250 only covers values that underflow.
constexpr double kRelTol = 1e-9;
constexpr double kAbsFloor = 1e-250;

TEST_P(SamplingTest, SampleReportsEvalPdfAndWeight) {
  const SamplingCase& c = GetParam();
  const auto bxdf = c.entry->make();
  const Vec3 wo = wo_of(c);
  Pcg32 rng(fnv1a(c.name) ^ 0x5bd1e995ULL);
  // Random u plus the edges of [0, 1): 0 and the largest double below 1.
  const double edge[] = {0.0, 0.5, std::nextafter(1.0, 0.0)};
  std::vector<std::pair<Point2, double>> us;
  for (double a : edge)
    for (double b : edge)
      for (double cc : edge) us.push_back({{a, b}, cc});
  for (int k = 0; k < 4000; ++k) us.push_back({{rng.uniform(), rng.uniform()}, rng.uniform()});
  int failures_reported = 0;
  int64_t ok = 0;
  for (const auto& [u, uc] : us) {
    const auto s = bxdf->sample(wo, u, uc);
    if (!s) continue;
    ++ok;
    const Rgb f = bxdf->eval(wo, s->wi);
    const double pdf = bxdf->pdf(wo, s->wi);
    const Rgb expected_weight = s->f * (s->wi.z / s->pdf);
    bool good = s->pdf > 0 && close(s->pdf, pdf, kRelTol, kAbsFloor);
    for (int ch = 0; ch < 3; ++ch) {
      good = good && close(s->f[ch], f[ch], kRelTol, kAbsFloor) &&
             close(s->weight[ch], expected_weight[ch], kRelTol, kAbsFloor);
    }
    if (!good && failures_reported++ < 5) {
      ADD_FAILURE() << c.entry->name << " wo = (" << wo.x << ", " << wo.y << ", " << wo.z << "), u = (" << u.x << ", "
                    << u.y << "), uc = " << uc << ": wi = (" << s->wi.x << ", " << s->wi.y << ", " << s->wi.z
                    << ")\n  sample f = " << s->f.r << " " << s->f.g << " " << s->f.b << ", eval = " << f.r << " "
                    << f.g << " " << f.b << "\n  sample pdf = " << s->pdf << ", pdf() = " << pdf
                    << "\n  weight = " << s->weight.r << " " << s->weight.g << " " << s->weight.b
                    << ", f cos / pdf = " << expected_weight.r << " " << expected_weight.g << " " << expected_weight.b;
    }
  }
  EXPECT_EQ(failures_reported, 0) << "inconsistent samples (first 5 shown above)";
  // Every model here can reflect from every wo above the horizon: some samples must succeed.
  EXPECT_GT(ok, 0);
}

// The weight f cos θi / pdf of visible-normal sampling is F G(wo, wi) / G1(wo) for the Smith forms (GGX and
// Beckmann: F G1(wi) separable, F (1 + Λo)/(1 + Λo + Λi) height-correlated, F G1s(wo) G1s(wi) / G1(wo) with Schlick's
// rational G1, which masks more than Smith's) and F G_V / G1_V(wo, wh) for the V-cavity form (V-groove masking), so
// it is at most F ≤ 1 at every wo, the grazing ones included: no fireflies in the transport. With the π
// denominator f is 4/π times larger, and so is the bound. Schlick's rational D has no Smith Λ of its own: its
// V-cavity sampling bounds the weight by F G max(1, (wo·wh) / (2 (n·wh)(n·wo))) ≈ 1.8 F G1(wi) tan θh / m at
// grazing wo, finite for every m (the D has compact support) though growing like 1/√m as m → 0 (its E itself exceeds
// 1 at grazing, BRDF.md, so no sampler can keep every weight ≤ 1 there). Measured: at most 8.2 over the catalogue
// (m = 0.1, cos θo = 1e-7), 103 at m = 1e-6, 11 at m = 1 (whose support reaches the horizon); the bound asserted
// is 3 (1 + 1/√m) + 10 m. Before visible-normal sampling,
// Beckmann's weight reached 25 at α = 1 and Cook–Torrance's grew as 2 (n·wi)/(n·wo) without bound. Tolerance 1e-6
// relative: the bound is exact algebra, and f and pdf are recomputed from wh = normalize(wo + wi), whose rounding
// moves the ratio by far less; 1e-3 at cos θo = 1e-7 with α = 1e-6, where wo·wh ≈ 1e-7 is itself a difference of
// rounded terms (measured: up to 7e-4 over 1 there).
double rational_d_bound(double m) { return 3.0 * (1.0 + 1.0 / std::sqrt(m)) + 10.0 * m; }

TEST(SamplingWeight, MicrofacetWeightsAreBoundedAtEveryAngle) {
  std::vector<const CatalogEntry*> entries;
  for (const CatalogEntry& e : model_catalog()) entries.push_back(&e);
  for (const CatalogEntry& e : extreme_catalog()) entries.push_back(&e);
  double worst_smith = 0.0, worst_vcavity = 0.0, worst_rational = 0.0;
  for (const CatalogEntry* e : entries) {
    if (!is_microfacet(e->spec.model)) continue;
    const auto bxdf = e->make();
    const bool rational = e->spec.distribution == brdf::Distribution::schlick_beckmann;
    const bool vgroove = e->spec.masking.value_or(e->spec.model == brdf::Model::cook_torrance
                                                      ? brdf::Masking::v_groove
                                                      : brdf::Masking::separable) == brdf::Masking::v_groove;
    double bound = rational && !vgroove ? rational_d_bound(e->spec.alpha_x) : 1.0;
    if (e->spec.normalization == brdf::Normalization::pi) bound *= 4.0 / kPi;
    Pcg32 rng(fnv1a(e->name));
    for (double cos_theta : {1.0, 0.9, 0.5, 0.1, 0.02, 1.7e-3, 1e-4, 1e-7}) {
      for (double phi : {0.3, 1.9}) {
        const double sin_theta = std::sqrt(1.0 - cos_theta * cos_theta);
        const Vec3 wo{sin_theta * std::cos(phi), sin_theta * std::sin(phi), cos_theta};
        double worst = 0.0;
        for (int k = 0; k < 4000; ++k) {
          const auto smp = bxdf->sample(wo, {rng.uniform(), rng.uniform()}, rng.uniform());
          if (smp) worst = std::fmax(worst, smp->weight.max());
        }
        const double rel_tol = cos_theta < 1e-6 && e->spec.alpha_x < 1e-3 ? 1e-3 : 1e-6;
        EXPECT_LE(worst, bound * (1.0 + rel_tol)) << e->name << " cos θo = " << cos_theta << ", φo = " << phi;
        double& w = rational && !vgroove ? worst_rational : vgroove ? worst_vcavity : worst_smith;
        if (e->spec.normalization != brdf::Normalization::pi) w = std::fmax(w, worst);
      }
    }
  }
  std::printf("max weight: Smith visible normals %.6f, V-cavity %.6f, Schlick's rational D (V-cavity) %.6f\n",
              worst_smith, worst_vcavity, worst_rational);
}

INSTANTIATE_TEST_SUITE_P(Catalog, SamplingTest, ::testing::ValuesIn(cases()),
                         [](const ::testing::TestParamInfo<SamplingCase>& info) { return info.param.name; });

}  // namespace
}  // namespace kiln::test
