// Helmholtz reciprocity f(wo, wi) = f(wi, wo) for every catalogue entry (and the extreme parameters), over random
// pairs: uniform on the hemisphere, drawn from the model's own lobe (where f is large and the terms that depend on
// the half vector matter), grazing on both sides, and near the normal.
//
// Tolerance: 1e-7 relative, about float precision. Every model's formula is symmetric in exact arithmetic; in double
// precision the two orders of evaluation round differently (e.g. the Fresnel term at wo·wh versus wi·wh, the sum
// 1 + Λ(wo) + Λ(wi) associated the other way), a few dozen operations of relative error 1.1e-16 each. The largest
// amplification is the cancellation in wo·wh for nearly opposite grazing pairs (relative error ~1e-16 / wo·wh with
// wo·wh ≥ ~1e-7 here), so rounding stays below ~1e-9; a real asymmetry (a cosine of the wrong direction, a
// one-sided term) is of order 1e-2 or more at random pairs.
// Absolute floor 1e-15 /sr, fifteen orders below the scale of a BRDF that reflects anything (ρ/π ≈ 0.3): such values
// carry no energy, and some formulas reach them through cancellations whose relative error is large although the
// absolute one is at rounding level (Schlick's (1 − wo·wh)^5 with c = 0 near the mirror direction, ~1e-43; the exact
// Fresnel for η = 1 ± 1e-12, ~1e-25). Those are reported as precision notes, not as reciprocity failures.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "bakers/math/constants.h"
#include "bakers/math/rng.h"
#include "tests/support/hemisphere.h"
#include "tests/support/model_catalog.h"
#include "tests/support/tolerance.h"

namespace kiln::test {
namespace {

constexpr double kRelTol = 1e-7;
constexpr double kAbsFloor = 1e-15;

uint64_t fnv1a(const std::string& s) {
  uint64_t h = 1469598103934665603ULL;
  for (unsigned char ch : s) h = (h ^ ch) * 1099511628211ULL;
  return h;
}

Vec3 with_cos(double c, double phi) {
  const double s = std::sqrt(std::fmax(0.0, 1.0 - c * c));
  return {s * std::cos(phi), s * std::sin(phi), c};
}

std::vector<const CatalogEntry*> all_entries() {
  std::vector<const CatalogEntry*> out;
  for (const CatalogEntry& e : model_catalog()) out.push_back(&e);
  for (const CatalogEntry& e : extreme_catalog()) out.push_back(&e);
  return out;
}

class ReciprocityTest : public ::testing::TestWithParam<const CatalogEntry*> {};

TEST_P(ReciprocityTest, DeclaredAsExpected) {
  const CatalogEntry& e = *GetParam();
  EXPECT_EQ(e.make()->reciprocal(), e.reciprocal) << e.name << ": the model's reciprocal() disagrees with the physics";
}

TEST_P(ReciprocityTest, SwappingDirectionsGivesTheSameValue) {
  const CatalogEntry& e = *GetParam();
  if (!e.reciprocal) GTEST_SKIP() << e.name << " is not expected to be reciprocal";
  const auto bxdf = e.make();
  Pcg32 rng(fnv1a(e.name));
  int failures = 0, compared = 0, nonzero = 0;
  double worst = 0;

  const auto check = [&](const char* kind, const Vec3& wo, const Vec3& wi) {
    const Rgb a = bxdf->eval(wo, wi), b = bxdf->eval(wi, wo);
    ++compared;
    if (!a.is_black()) ++nonzero;
    for (int ch = 0; ch < 3; ++ch) {
      const double m = std::fmax(std::fabs(a[ch]), std::fabs(b[ch]));
      if (m > kAbsFloor) worst = std::fmax(worst, std::fabs(a[ch] - b[ch]) / m);
      if (!close(a[ch], b[ch], kRelTol, kAbsFloor) && failures++ < 5) {
        std::ostringstream s;
        s.precision(17);
        s << e.name << " (" << kind << "): wo = (" << wo.x << ", " << wo.y << ", " << wo.z << "), wi = (" << wi.x
          << ", " << wi.y << ", " << wi.z << "), channel " << ch << ": f(wo, wi) = " << a[ch]
          << ", f(wi, wo) = " << b[ch];
        ADD_FAILURE() << s.str();
      }
    }
  };

  for (int k = 0; k < 20000; ++k) {
    // Uniform pairs on the hemisphere.
    check("uniform", sample_uniform_hemisphere({rng.uniform(), rng.uniform()}),
          sample_uniform_hemisphere({rng.uniform(), rng.uniform()}));
    // wi from the model's own sampling: the lobe, where the BRDF is large.
    const Vec3 wo = sample_uniform_hemisphere({rng.uniform(), rng.uniform()});
    if (const auto s = bxdf->sample(wo, {rng.uniform(), rng.uniform()}, rng.uniform())) check("lobe", wo, s->wi);
  }
  for (int k = 0; k < 5000; ++k) {
    // Grazing on both sides (cos θ from 1e-7 to 1e-1), and near the normal (sin θ from 1e-8 to 1e-1).
    const auto grazing = [&] { return with_cos(std::pow(10.0, -1.0 - 6.0 * rng.uniform()), 2 * kPi * rng.uniform()); };
    check("grazing", grazing(), grazing());
    check("grazing-uniform", grazing(), sample_uniform_hemisphere({rng.uniform(), rng.uniform()}));
    const auto near_normal = [&] {
      const double s = std::pow(10.0, -1.0 - 7.0 * rng.uniform()), phi = 2 * kPi * rng.uniform();
      return Vec3{s * std::cos(phi), s * std::sin(phi), std::sqrt(1 - s * s)};
    };
    check("near-normal", near_normal(), sample_uniform_hemisphere({rng.uniform(), rng.uniform()}));
  }
  EXPECT_EQ(failures, 0) << e.name << ": " << failures << " of " << compared << " pairs not reciprocal (first 5 above)";
  // The check is only meaningful where the BRDF is not zero: some pairs must reflect something, except for the forms
  // that reflect nothing at all (η = 1 with the exact Fresnel: no interface; black albedo or C).
  const bool black_by_design = (e.spec.fresnel == brdf::FresnelMode::exact && e.spec.eta == 1.0 &&
                                (e.spec.model == brdf::Model::ggx || e.spec.model == brdf::Model::beckmann ||
                                 e.spec.model == brdf::Model::cook_torrance)) ||
                               ((e.spec.model == brdf::Model::lambert || e.spec.model == brdf::Model::oren_nayar ||
                                 e.spec.model == brdf::Model::oren_nayar_simple) &&
                                e.spec.albedo.is_black()) ||
                               (e.spec.model == brdf::Model::schlick && e.spec.layer.c.is_black());
  if (!black_by_design) {
    EXPECT_GT(nonzero, 0) << e.name;
  }
  std::cout << "[reciprocity] " << e.name << ": " << compared << " pairs, " << nonzero
            << " non-zero, worst relative difference (values above the floor) " << worst << "\n";
}

INSTANTIATE_TEST_SUITE_P(Catalog, ReciprocityTest, ::testing::ValuesIn(all_entries()),
                         [](const ::testing::TestParamInfo<const CatalogEntry*>& info) { return info.param->name; });

}  // namespace
}  // namespace kiln::test
