// Numerical stability of every model under adversarial and random inputs (hard cases stay stable; bxdf.h contract):
// for the catalogue and for extreme parameters (α = 1e-6 and 1, σ = 0 and π/2, η = 1, η → 1, η ≪ 1, η = 10,
// f0 = 0 and 1, Schlick r and p = 0 and 1), with directions on and near the normal and the horizon, below it,
// opposite (wi = −wo), equal, mirrored, with NaN, Inf and denormal components:
// - eval and pdf are finite and non-negative, and zero for every pair the contract says reflects nothing;
// - sample either fails or returns a finite unit wi with wi.z > 0, pdf > 0 finite, f and weight finite non-negative,
//   and always fails for a wo that reflects nothing.
// Each failure names the entry and the adversarial case. About 8 million calls in total.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "bakers/math/constants.h"
#include "bakers/math/rng.h"
#include "tests/support/hemisphere.h"
#include "tests/support/model_catalog.h"

namespace kiln::test {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kDenormMin = std::numeric_limits<double>::denorm_min();
const double kBelowOne = std::nextafter(1.0, 0.0);

struct NamedDirection {
  std::string name;
  Vec3 w;
};

// Unit direction with the given cos θ at azimuth phi, built from the components so that tiny cosines are exact.
Vec3 with_cos(double c, double phi) {
  const double s = std::sqrt(std::fmax(0.0, 1.0 - c * c));
  return {s * std::cos(phi), s * std::sin(phi), c};
}

std::vector<NamedDirection> adversarial_directions() {
  return {
      {"normal", {0, 0, 1}},
      {"near_normal_sin1e-8", {1e-8, 0, 1}},
      {"near_normal_sin1e-150", {1e-150, -1e-150, 1}},
      {"normal_with_denormal_x", {kDenormMin, 0, 1}},
      {"normal_with_negative_zero_xy", {-0.0, -0.0, 1}},
      {"typical", {0.3, 0.4, std::sqrt(0.75)}},
      {"theta60_phi200", spherical_direction(kPi / 3, 200 * kPi / 180)},
      {"theta85_phi45", spherical_direction(85 * kPi / 180, kPiOver4)},
      {"theta89_9_phi90", spherical_direction(89.9 * kPi / 180, kPiOver2)},
      {"cos1e-7_x", with_cos(1e-7, 0)},
      {"cos1e-7_y", with_cos(1e-7, kPiOver2)},
      {"cos1e-7_phi135", with_cos(1e-7, 3 * kPiOver4)},
      {"cos1e-15", with_cos(1e-15, 1.0)},
      {"cos1e-300", with_cos(1e-300, 2.0)},
      {"cos_denormal_min", {1, 0, kDenormMin}},
      {"cos_denormal_1e-310", {0.6, 0.8, 1e-310}},
      {"horizon_x", {1, 0, 0}},
      {"horizon_diag", {std::sqrt(0.5), std::sqrt(0.5), 0}},
      {"horizon_negative_zero_z", {0, 1, -0.0}},
      {"below_cos-1e-7", with_cos(-1e-7, 0.5)},
      {"below_cos-denormal", {1, 0, -kDenormMin}},
      {"back_facing_theta143", {0.6, 0, -0.8}},
      {"straight_down", {0, 0, -1}},
      {"nan_x", {kNaN, 0, 1}},
      {"nan_z", {0, 0, kNaN}},
      {"all_nan", {kNaN, kNaN, kNaN}},
      {"inf_x", {kInf, 0, 1}},
      {"minus_inf_y", {0, -kInf, 1}},
      {"inf_z", {0, 0, kInf}},
      {"minus_inf_z", {0, 0, -kInf}},
      {"inf_and_nan", {kInf, kNaN, 1}},
      {"zero_vector", {0, 0, 0}},
      // Other non-unit directions are out of the contract (bxdf.h: directions are expected to be unit length).
  };
}

// A direction that the contract says reflects nothing (as wo or wi): NaN/Inf or at or below the horizon.
bool reflects_nothing(const Vec3& w) { return !(w.z > 0) || !is_finite(w); }
bool is_unit(const Vec3& w) { return std::fabs(length(w) - 1.0) <= 1e-12; }

std::string str(const Vec3& v) {
  std::ostringstream s;
  s.precision(17);
  s << "(" << v.x << ", " << v.y << ", " << v.z << ")";
  return s.str();
}
std::string str(const Rgb& c) {
  std::ostringstream s;
  s.precision(17);
  s << "(" << c.r << ", " << c.g << ", " << c.b << ")";
  return s.str();
}

bool finite_non_negative(const Rgb& c) { return c.is_finite() && c.min() >= 0; }

// Collects failures for one entry; reports the first few in full and counts the rest.
class Checker {
 public:
  Checker(const CatalogEntry& e, const brdf::Bxdf& b) : entry_(e), bxdf_(b) {}
  ~Checker() { EXPECT_EQ(failures_, 0) << entry_.name << ": " << failures_ << " failed checks (first shown above)"; }

  int64_t calls() const { return calls_; }

  // The case is named by `label` and, for random cases, their index (names are only built on failure).
  void check_pair(const std::string& label, int index, const Vec3& wo, const Vec3& wi) {
    const Rgb f = bxdf_.eval(wo, wi);
    const double pdf = bxdf_.pdf(wo, wi);
    calls_ += 2;
    const bool nothing = reflects_nothing(wo) || reflects_nothing(wi);
    const auto case_name = [&] { return index < 0 ? label : label + " #" + std::to_string(index); };
    if (!finite_non_negative(f)) fail(case_name, wo, wi, "eval not finite and non-negative: " + str(f));
    if (!(std::isfinite(pdf) && pdf >= 0))
      fail(case_name, wo, wi, "pdf not finite and non-negative: " + std::to_string(pdf));
    if (nothing && !f.is_black()) fail(case_name, wo, wi, "eval must be 0 for this pair (bxdf.h), got " + str(f));
    if (nothing && pdf != 0)
      fail(case_name, wo, wi, "pdf must be 0 for this pair (bxdf.h), got " + std::to_string(pdf));
  }

  void check_sample(const std::string& label, int index, const Vec3& wo, Point2 u, double uc) {
    const auto s = bxdf_.sample(wo, u, uc);
    ++calls_;
    if (!s) return;
    const auto case_name = [&] { return index < 0 ? label : label + " #" + std::to_string(index); };
    std::ostringstream where;
    where.precision(17);
    where << "u = (" << u.x << ", " << u.y << "), uc = " << uc;
    const std::string w = where.str();
    if (reflects_nothing(wo)) fail(case_name, wo, s->wi, "sample must fail for this wo (bxdf.h); " + w);
    if (!is_finite(s->wi) || !(s->wi.z > 0)) fail(case_name, wo, s->wi, "sampled wi not finite above horizon; " + w);
    // Unit length is only promised for unit wo.
    if (is_unit(wo) && is_finite(s->wi) && std::fabs(length(s->wi) - 1.0) > 1e-9)
      fail(case_name, wo, s->wi, "sampled wi not unit length (" + std::to_string(length(s->wi)) + "); " + w);
    if (!(s->pdf > 0) || !std::isfinite(s->pdf))
      fail(case_name, wo, s->wi, "sample pdf not finite and positive: " + std::to_string(s->pdf) + "; " + w);
    if (!finite_non_negative(s->f))
      fail(case_name, wo, s->wi, "sample f not finite non-negative " + str(s->f) + "; " + w);
    if (!finite_non_negative(s->weight))
      fail(case_name, wo, s->wi, "sample weight not finite non-negative " + str(s->weight) + "; " + w);
  }

 private:
  template <typename Name>
  void fail(const Name& case_name, const Vec3& wo, const Vec3& wi, const std::string& what) {
    if (failures_++ < 8) {
      ADD_FAILURE() << entry_.name << " [" << bxdf_.describe() << "], case " << case_name() << ": wo = " << str(wo)
                    << ", wi = " << str(wi) << ": " << what;
    }
  }

  const CatalogEntry& entry_;
  const brdf::Bxdf& bxdf_;
  int64_t failures_ = 0;
  int64_t calls_ = 0;
};

// Random directions from a mixture that puts most of its mass where formulas break: near the horizon (cos θ down to
// 1e-16, and on to the denormals where products of cosines underflow), near the normal (sin θ down to 1e-16),
// anywhere on the sphere (back-facing half the time), and rarely exactly on the horizon or the normal.
Vec3 random_direction(Pcg32& rng) {
  const double phi = 2 * kPi * rng.uniform();
  switch (static_cast<int>(rng.uniform() * 7)) {
    case 0:
      return with_cos(std::pow(10.0, -16.0 * rng.uniform()), phi);
    case 6:
      return with_cos(std::pow(10.0, -16.0 - 308.0 * rng.uniform()), phi);
    case 1: {
      const double s = std::pow(10.0, -16.0 * rng.uniform());
      return {s * std::cos(phi), s * std::sin(phi), std::sqrt(1 - s * s)};
    }
    case 2:
      return sample_uniform_sphere({rng.uniform(), rng.uniform()});
    case 3:
      return rng.uniform() < 0.5 ? with_cos(0.0, phi) : Vec3{0, 0, 1};
    default:
      return sample_uniform_hemisphere({rng.uniform(), rng.uniform()});
  }
}

// A second direction related to the first: the mirror direction (the specular peak), wi = −wo, wi = wo, each slightly
// perturbed, or independent.
Vec3 related_direction(Pcg32& rng, const Vec3& wo) {
  const double eps = std::pow(10.0, -15.0 * rng.uniform());
  const Vec3 jitter{eps * (rng.uniform() - 0.5), eps * (rng.uniform() - 0.5), eps * (rng.uniform() - 0.5)};
  switch (static_cast<int>(rng.uniform() * 5)) {
    case 0:
      return normalize(Vec3{-wo.x, -wo.y, wo.z} + jitter);
    case 1:
      return normalize(-wo + jitter);
    case 2:
      return normalize(wo + jitter);
    default:
      return random_direction(rng);
  }
}

double random_u(Pcg32& rng) {
  // 10% exact edges of [0, 1).
  const double r = rng.uniform();
  if (r < 0.05) return 0.0;
  if (r < 0.10) return kBelowOne;
  return rng.uniform();
}

uint64_t fnv1a(const std::string& s) {
  uint64_t h = 1469598103934665603ULL;
  for (unsigned char ch : s) h = (h ^ ch) * 1099511628211ULL;
  return h;
}

std::vector<const CatalogEntry*> all_entries() {
  std::vector<const CatalogEntry*> out;
  for (const CatalogEntry& e : model_catalog()) out.push_back(&e);
  for (const CatalogEntry& e : extreme_catalog()) out.push_back(&e);
  return out;
}

TEST(StabilityCatalogue, EveryEntryIsValidAndNamedUniquely) {
  std::set<std::string> names;
  for (const CatalogEntry* e : all_entries()) {
    EXPECT_TRUE(names.insert(e->name).second) << "duplicate name " << e->name;
    const auto error = brdf::validate(e->spec);
    EXPECT_FALSE(error.has_value()) << e->name << ": " << (error ? error->what() : "");
  }
}

class StabilityTest : public ::testing::TestWithParam<const CatalogEntry*> {};

TEST_P(StabilityTest, FiniteNonNegativeAndContractEdges) {
  const CatalogEntry& entry = *GetParam();
  const auto bxdf = entry.make();
  Checker check(entry, *bxdf);

  // Every adversarial pair, plus the directions derived from each wo.
  const std::vector<NamedDirection> dirs = adversarial_directions();
  for (const NamedDirection& o : dirs) {
    for (const NamedDirection& i : dirs) check.check_pair("wo=" + o.name + " wi=" + i.name, -1, o.w, i.w);
    const Vec3 mirror{-o.w.x, -o.w.y, o.w.z};
    check.check_pair("wo=" + o.name + " wi=-wo", -1, o.w, -o.w);
    check.check_pair("wo=" + o.name + " wi=wo", -1, o.w, o.w);
    check.check_pair("wo=" + o.name + " wi=reflect(wo)", -1, o.w, mirror);
    check.check_pair("wo=" + o.name + " wi=reflect(wo)+1e-12", -1, o.w, normalize(mirror + Vec3{1e-12, -1e-12, 0}));
    check.check_pair("wo=" + o.name + " wi=normal", -1, o.w, Vec3{0, 0, 1});
    // Samples at the corners and centre of [0, 1)² × [0, 1).
    for (double ux : {0.0, 1e-300, 0.5, kBelowOne})
      for (double uy : {0.0, 0.25, kBelowOne})
        for (double uc : {0.0, 0.5, kBelowOne}) check.check_sample("wo=" + o.name + " u=edges", -1, o.w, {ux, uy}, uc);
  }

  // Random pairs and samples from the adversarial mixture.
  Pcg32 rng(fnv1a(entry.name));
  for (int k = 0; k < 15000; ++k) {
    const Vec3 wo = random_direction(rng);
    const Vec3 wi = related_direction(rng, wo);
    check.check_pair("random pair", k, wo, wi);
    check.check_pair("random pair swapped", k, wi, wo);
    check.check_sample("random sample", k, wo, {random_u(rng), random_u(rng)}, random_u(rng));
  }
  // Samples of the lobe fed back as pairs: the lobe's peak is where values get large.
  for (int k = 0; k < 3000; ++k) {
    const Vec3 wo = random_direction(rng);
    const auto s = bxdf->sample(wo, {rng.uniform(), rng.uniform()}, rng.uniform());
    if (s) check.check_pair("sampled pair", k, wo, s->wi);
  }
  RecordProperty("calls", static_cast<int>(check.calls()));
}

INSTANTIATE_TEST_SUITE_P(Catalog, StabilityTest, ::testing::ValuesIn(all_entries()),
                         [](const ::testing::TestParamInfo<const CatalogEntry*>& info) { return info.param->name; });

}  // namespace
}  // namespace kiln::test
