// The MERL tabulation: file layout, Rusinkiewicz coordinates, exact values for Lambert, and GGX lookups near cell
// centres within a tolerance derived from the cell size.
#include "bakers/material/merl.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>

#include "bakers/brdf/model_spec.h"
#include "bakers/math/constants.h"
#include "bakers/math/rng.h"

namespace kiln::material {
namespace {

int32_t header_int(const std::string& bytes, int k) {
  int32_t v;
  std::memcpy(&v, bytes.data() + 4 * k, 4);  // the test machine is little-endian like the format
  return v;
}
double file_double(const std::string& bytes, size_t k) {
  double v;
  std::memcpy(&v, bytes.data() + 12 + 8 * k, 8);
  return v;
}

// Angles of a continuous index triple (the inverse of MERL's index maps).
double theta_h_of(double index) { return (index / kMerlThetaH) * (index / kMerlThetaH) * kPiOver2; }
double theta_d_of(double index) { return index / kMerlThetaD * kPiOver2; }
double phi_d_of(double index) { return index / kMerlPhiD * kPi; }

std::string message_of(const std::string& bytes) {
  try {
    decode_merl(bytes);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "(accepted)";
}

class MerlFiles : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    brdf::ModelSpec lambert;
    lambert.albedo = Rgb{0.2, 0.5, 0.8};
    lambert_bytes_ = new std::string(encode_merl(*brdf::make_bxdf(lambert)));
  }
  static void TearDownTestSuite() { delete lambert_bytes_; }
  static const std::string& lambert_bytes() { return *lambert_bytes_; }

 private:
  static std::string* lambert_bytes_;
};
std::string* MerlFiles::lambert_bytes_ = nullptr;

TEST_F(MerlFiles, SizeAndHeaderAreMerls) {
  const std::string& bytes = lambert_bytes();
  EXPECT_EQ(bytes.size(), size_t{12} + 8 * 3 * 90 * 90 * 180);
  EXPECT_EQ(header_int(bytes, 0), 90);
  EXPECT_EQ(header_int(bytes, 1), 90);
  EXPECT_EQ(header_int(bytes, 2), 180);
}

TEST_F(MerlFiles, LambertTabulatesToRhoOverPiWhereverTheCellCentreIsAboveTheHorizon) {
  const Rgb rho{0.2, 0.5, 0.8};
  const std::string& bytes = lambert_bytes();
  const MerlTable table = decode_merl(bytes);
  size_t above = 0;
  for (int ih = 0; ih < kMerlThetaH; ++ih) {
    for (int id = 0; id < kMerlThetaD; ++id) {
      for (int ip = 0; ip < kMerlPhiD; ++ip) {
        const MerlDirections w = merl_directions(theta_h_of(ih + 0.5), theta_d_of(id + 0.5), phi_d_of(ip + 0.5));
        const size_t k = MerlTable::merl_index(ih, id, ip);
        const Rgb& f = table.f[k];
        // f / scale then × scale: two roundings of a double, so a few ulps. A cell whose centre is below the
        // horizon holds 0 (wholly below) or the mean of the constant over its part above: ρ/π again, up to the
        // rounding of a sum of at most 16³ equal terms (≤ 4096 ε relative; 1e-13 allows for it).
        const bool centre_above = brdf::valid_reflection_pair(w.wo, w.wi);
        if (centre_above) ++above;
        for (int c = 0; c < 3; ++c) {
          if (!centre_above && f[c] == 0) continue;
          ASSERT_NEAR(f[c], rho[c] / kPi, (centre_above ? 8e-16 : 1e-13) * rho[c] / kPi)
              << ih << " " << id << " " << ip;
        }
      }
    }
  }
  // Half of the (θ_h, θ_d) quarter plane has both directions above the horizon, roughly.
  EXPECT_GT(above, kMerlEntries / 3);
  // The stored numbers themselves are f / scale, as a MERL reader expects: R = ρ/π · 1500 and so on.
  const size_t k0 = MerlTable::merl_index(0, 0, 0);
  EXPECT_NEAR(file_double(bytes, k0), 0.2 / kPi * 1500.0, 1e-12);
  EXPECT_NEAR(file_double(bytes, kMerlEntries + k0), 0.5 / kPi * 1500.0 / 1.15, 1e-12);
  EXPECT_NEAR(file_double(bytes, 2 * kMerlEntries + k0), 0.8 / kPi * 1500.0 / 1.66, 1e-12);
}

TEST(MerlCoordinates, KnownConfigurations) {
  // Mirror configuration in the x-z plane: h is the normal, θ_d is the angle of incidence, φ_d = 0.
  const double a = 0.7;
  const Vec3 wi{std::sin(a), 0, std::cos(a)}, wo{-std::sin(a), 0, std::cos(a)};
  const MerlCoordinates c = merl_coordinates(wo, wi);
  EXPECT_NEAR(c.theta_h, 0.0, 1e-7);  // acos near 1 loses half the digits
  EXPECT_NEAR(c.theta_d, a, 1e-12);
  EXPECT_NEAR(c.index_d, a / kPiOver2 * 90, 1e-10);
  // Retro-reflection: wi = wo, so h = wi and θ_d = 0.
  const Vec3 w = normalize(Vec3{0.3, -0.4, 0.8});
  const MerlCoordinates r = merl_coordinates(w, w);
  EXPECT_NEAR(r.theta_h, std::acos(w.z), 1e-12);
  EXPECT_NEAR(r.theta_d, 0.0, 1e-7);
  // The θ_h index is non-linear: θ_h = π/8 is a quarter of the range, index sqrt(1/4) · 90 = 45.
  const MerlDirections d = merl_directions(kPi / 8, 0.3, 1.0);
  EXPECT_NEAR(merl_coordinates(d.wo, d.wi).index_h, 45.0, 1e-9);
}

TEST(MerlCoordinates, DirectionsAndCoordinatesInvertEachOtherAndSwappingIsFolded) {
  Pcg32 rng(3);
  for (int k = 0; k < 2000; ++k) {
    const double th = rng.uniform() * kPiOver2 * 0.98 + 0.01, td = rng.uniform() * kPiOver2 * 0.98 + 0.01;
    const double pd = rng.uniform() * kPi * 0.998 + 0.001, ph = rng.uniform() * 2 * kPi;
    const MerlDirections w = merl_directions(th, td, pd, ph);
    const MerlCoordinates c = merl_coordinates(w.wo, w.wi);
    EXPECT_NEAR(c.theta_h, th, 1e-9);
    EXPECT_NEAR(c.theta_d, td, 1e-9);
    EXPECT_NEAR(c.phi_d, pd, 1e-9);
    // wi and wo swapped is φ_d + π, which MERL folds back onto the same φ_d.
    EXPECT_NEAR(merl_coordinates(w.wi, w.wo).phi_d, pd, 1e-9);
  }
}

brdf::ModelSpec coloured_ggx() {
  brdf::ModelSpec spec;
  spec.model = brdf::Model::ggx;
  spec.alpha_x = spec.alpha_y = 0.3;
  spec.fresnel = brdf::FresnelMode::schlick;
  spec.f0 = Rgb{0.04, 0.5, 0.9};
  return spec;
}

class MerlGgx : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    bxdf_ = brdf::make_bxdf(coloured_ggx()).release();
    table_ = new MerlTable(decode_merl(encode_merl(*bxdf_)));
  }
  static void TearDownTestSuite() {
    delete table_;
    delete bxdf_;
  }
  static const brdf::Bxdf* bxdf_;
  static const MerlTable* table_;
};
const brdf::Bxdf* MerlGgx::bxdf_ = nullptr;
const MerlTable* MerlGgx::table_ = nullptr;

// A random query a tenth of a cell or less from a random cell centre, as continuous indices and directions.
struct Query {
  double c[3], x[3];
  MerlDirections w;
};
Query random_query(Pcg32& rng) {
  Query q;
  q.c[0] = rng.next_u32() % kMerlThetaH + 0.5;
  q.c[1] = rng.next_u32() % kMerlThetaD + 0.5;
  q.c[2] = rng.next_u32() % kMerlPhiD + 0.5;
  for (int a = 0; a < 3; ++a) q.x[a] = q.c[a] + 0.2 * (rng.uniform() - 0.5);
  const double phi_h = 2 * kPi * rng.uniform();  // isotropic: the azimuth of h must not matter
  q.w = merl_directions(theta_h_of(q.x[0]), theta_d_of(q.x[1]), phi_d_of(q.x[2]), phi_h);
  if (rng.uniform() < 0.5) std::swap(q.w.wo, q.w.wi);  // reciprocity: either direction may be "in"
  return q;
}
Rgb f_at(const brdf::Bxdf& bxdf, const double* idx) {
  const MerlDirections w = merl_directions(theta_h_of(idx[0]), theta_d_of(idx[1]), phi_d_of(idx[2]));
  return bxdf.eval(w.wo, w.wi);
}
bool centre_above(const Query& q) {
  const MerlDirections w = merl_directions(theta_h_of(q.c[0]), theta_d_of(q.c[1]), phi_d_of(q.c[2]));
  return brdf::valid_reflection_pair(w.wo, w.wi);
}

// GGX with a coloured Schlick Fresnel. The table holds f at each cell centre c; a query at x = c + δ (δ in index
// units, |δ_k| ≤ 0.1, so x stays in the cell and the reader's truncation finds it) differs from the centre by
// f(x) − f(c) ≈ Σ_k ∂_k f · δ_k. We measure each ∂_k f as the central difference over one whole cell,
// f(c + ½ e_k) − f(c − ½ e_k), and accept twice the resulting first-order bound (curvature over a tenth of a cell
// is a small fraction of it: α = 0.3 makes f vary over tens of cells) plus 1e-12 relative for rounding.
TEST_F(MerlGgx, LookupNearCellCentresMatchesEvalWithinTheCellSizeBound) {
  Pcg32 rng(11);
  int checked = 0;
  double worst_relative = 0;
  for (int k = 0; k < 20000; ++k) {
    const Query q = random_query(rng);
    if (!brdf::valid_reflection_pair(q.w.wo, q.w.wi) || !centre_above(q)) continue;  // next test
    const Rgb looked_up = lookup(*table_, q.w.wo, q.w.wi);
    const Rgb exact = bxdf_->eval(q.w.wo, q.w.wi);
    Rgb bound;
    for (int a = 0; a < 3; ++a) {
      double lo[3] = {q.c[0], q.c[1], q.c[2]}, hi[3] = {q.c[0], q.c[1], q.c[2]};
      lo[a] -= 0.5;
      hi[a] += 0.5;
      const Rgb diff = f_at(*bxdf_, hi) - f_at(*bxdf_, lo);
      bound += Rgb{std::fabs(diff.r), std::fabs(diff.g), std::fabs(diff.b)} * std::fabs(q.x[a] - q.c[a]);
    }
    for (int ch = 0; ch < 3; ++ch) {
      const double tol = 2.0 * bound[ch] + 1e-12 * exact[ch];
      ASSERT_LE(std::fabs(looked_up[ch] - exact[ch]), tol)
          << "cell " << q.c[0] << "," << q.c[1] << "," << q.c[2] << " channel " << ch << ": lookup " << looked_up[ch]
          << " eval " << exact[ch];
      if (exact[ch] > 0) worst_relative = std::fmax(worst_relative, std::fabs(looked_up[ch] - exact[ch]) / exact[ch]);
    }
    ++checked;
  }
  EXPECT_GT(checked, 8000);
  // For the record: the largest relative difference a tenth of a cell away from the centres.
  RecordProperty("worst_relative_difference", std::to_string(worst_relative));
}

// Cells whose centre is below the horizon but which reach above it hold the mean of f over their part above, so a
// lookup there is off by at most the variation of f over that part of the closed cell (measured on a 9×9×9 lattice
// from face to face, finer than the table's 4×4×4 grid and including the corners a sliver falls back to, plus 2% of
// f for the lattice missing the extremes), and never 0 where f is not.
TEST_F(MerlGgx, LookupJustAboveTheHorizonFindsTheCellsMeanNotZero) {
  Pcg32 rng(12);
  int checked = 0;
  for (int k = 0; k < 400000 && checked < 300; ++k) {
    Query q = random_query(rng);
    if (centre_above(q)) continue;
    // Anywhere in the cell, not only near the centre: the part above may lie near a face.
    for (int a = 0; a < 3; ++a) q.x[a] = q.c[a] - 0.5 + rng.uniform();
    q.w = merl_directions(theta_h_of(q.x[0]), theta_d_of(q.x[1]), phi_d_of(q.x[2]));
    if (!brdf::valid_reflection_pair(q.w.wo, q.w.wi)) continue;
    Rgb lo{1e300}, hi{0.0};
    for (int a = 0; a <= 8; ++a)
      for (int b = 0; b <= 8; ++b)
        for (int c = 0; c <= 8; ++c) {
          const double idx[3] = {q.c[0] - 0.5 + a / 8.0, q.c[1] - 0.5 + b / 8.0, q.c[2] - 0.5 + c / 8.0};
          const MerlDirections w = merl_directions(theta_h_of(idx[0]), theta_d_of(idx[1]), phi_d_of(idx[2]));
          if (!brdf::valid_reflection_pair(w.wo, w.wi)) continue;
          const Rgb f = bxdf_->eval(w.wo, w.wi);
          lo = Rgb{std::fmin(lo.r, f.r), std::fmin(lo.g, f.g), std::fmin(lo.b, f.b)};
          hi = Rgb{std::fmax(hi.r, f.r), std::fmax(hi.g, f.g), std::fmax(hi.b, f.b)};
        }
    const Rgb looked_up = lookup(*table_, q.w.wo, q.w.wi);
    const Rgb exact = bxdf_->eval(q.w.wo, q.w.wi);
    for (int ch = 0; ch < 3; ++ch) {
      ASSERT_GT(looked_up[ch], 0.0) << "cell " << q.c[0] << "," << q.c[1] << "," << q.c[2];
      const double spread = hi[ch] >= lo[ch] ? hi[ch] - lo[ch] : 0.0;
      ASSERT_LE(std::fabs(looked_up[ch] - exact[ch]), spread + 0.02 * exact[ch])
          << "cell " << q.c[0] << "," << q.c[1] << "," << q.c[2] << " channel " << ch;
    }
    ++checked;
  }
  EXPECT_GE(checked, 100);
}

TEST(MerlLookup, BelowTheHorizonIsZero) {
  MerlTable table;
  table.f.assign(kMerlEntries, Rgb{1.0});
  EXPECT_EQ(lookup(table, Vec3{0, 0, 1}, Vec3{1, 0, 0}), Rgb{});
  EXPECT_EQ(lookup(table, Vec3{0, 0, -1}, Vec3{0, 0, 1}), Rgb{});
  EXPECT_EQ(lookup(table, Vec3{0, 0, 1}, Vec3{0, 0, 1}), Rgb{1.0});
}

TEST_F(MerlFiles, MalformedFilesAreRejectedWithAClearError) {
  const std::string& good = lambert_bytes();
  EXPECT_NE(message_of("").find("12-byte header"), std::string::npos);
  EXPECT_NE(message_of(good.substr(0, 8)).find("12-byte header"), std::string::npos);

  std::string dims = good;
  const int32_t wrong = 360;  // the full φ_d range: another layout, not MERL's
  std::memcpy(dims.data() + 8, &wrong, 4);
  const std::string m = message_of(dims);
  EXPECT_NE(m.find("dimensions 90 x 90 x 360"), std::string::npos) << m;

  EXPECT_NE(message_of(good.substr(0, good.size() - 1)).find("truncated"), std::string::npos);
  EXPECT_NE(message_of(good.substr(0, 12)).find("truncated"), std::string::npos);
  EXPECT_NE(message_of(good + std::string(8, '\0')).find("extra data"), std::string::npos);

  std::string nan = good;
  const double bad = std::nan("");
  std::memcpy(nan.data() + 12 + 8 * 1000, &bad, 8);
  EXPECT_NE(message_of(nan).find("finite"), std::string::npos) << message_of(nan);
}

TEST(MerlOptionsCheck, AzimuthCountIsChecked) {
  brdf::ModelSpec spec;
  MerlOptions o;
  o.phi_h_samples = 0;
  EXPECT_THROW(tabulate_merl(*brdf::make_bxdf(spec), o), std::invalid_argument);
}

}  // namespace
}  // namespace kiln::material
