// The kiln-brdf program: its answers agree with closed forms, and bad input gets one line and a non-zero exit.
#include <gtest/gtest.h>

#include <cstdlib>
#include <sstream>
#include <string>

#include "bakers/math/constants.h"
#include "tests/support/run_command.h"

namespace {

struct Result {
  int status = -1;
  std::string out;  // stdout and stderr together
};

Result run(const std::string& args) {
  const kiln::test::CommandResult r = kiln::test::run_command(std::string(KILN_BRDF_BIN) + " " + args + " 2>&1");
  return {r.status, r.output};
}

double first_number(const std::string& s) { return std::strtod(s.c_str(), nullptr); }

TEST(KilnBrdfCli, LambertEvalIsAlbedoOverPi) {
  const Result r = run("eval --model lambert --albedo 0.5 --wo 0,0,1 --wi 1,0,1");
  ASSERT_EQ(r.status, 0) << r.out;
  // The value is printed with round-trip precision, so it equals 0.5/π to double precision.
  EXPECT_DOUBLE_EQ(first_number(r.out), 0.5 * kiln::kInvPi);
}

TEST(KilnBrdfCli, RgbAlbedoPrintsThreeValues) {
  const Result r = run("eval --model lambert --albedo 0.1,0.2,0.3 --wo 0,0,1 --wi 0,0,1");
  ASSERT_EQ(r.status, 0) << r.out;
  std::istringstream in(r.out);
  double a, b, c;
  in >> a >> b >> c;
  EXPECT_DOUBLE_EQ(a, 0.1 * kiln::kInvPi);
  EXPECT_DOUBLE_EQ(b, 0.2 * kiln::kInvPi);
  EXPECT_DOUBLE_EQ(c, 0.3 * kiln::kInvPi);
}

TEST(KilnBrdfCli, GgxAtNormalIncidenceMatchesClosedForm) {
  // wo = wi = n: wh = n, D = 1/(π α²), G1 = 1 for both, F = 1 → f = 1 / (4 π α²).
  const Result r = run("eval --model ggx --alpha 0.5 --wo 0,0,1 --wi 0,0,1");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NEAR(first_number(r.out), 1.0 / (4.0 * kiln::kPi * 0.25), 1e-12);
}

// Directions are normalised by their largest component first: 1e308 squared overflows and 1e-320 squared
// underflows, yet both scale to the same unit vectors as 1,0,1 and 0,0,1. The results must be identical bits: the
// scaled vectors are (1, 0, 1) and (0, 0, 1) exactly (x/x = 1 for any finite non-zero x, denormals included).
TEST(KilnBrdfCli, HugeAndTinyDirectionsNormaliseLikeOrdinaryOnes) {
  const Result ordinary = run("eval --model ggx --alpha 0.5 --wo 0,0,1 --wi 1,0,1");
  ASSERT_EQ(ordinary.status, 0) << ordinary.out;
  for (const char* args : {"eval --model ggx --alpha 0.5 --wo 0,0,1e308 --wi 1e308,0,1e308",
                           "eval --model ggx --alpha 0.5 --wo 0,0,1e-320 --wi 1e-320,0,1e-320",
                           "eval --model ggx --alpha 0.5 --wo 0,0,1.7e308 --wi 1.7e308,0,1.7e308",
                           "eval --model ggx --alpha 0.5 --wo -0,0,5e-324 --wi 1e-300,0,1e-300"}) {
    const Result r = run(args);
    ASSERT_EQ(r.status, 0) << args << ": " << r.out;
    EXPECT_EQ(r.out, ordinary.out) << args;
  }
  // A mixed vector whose small components vanish next to the large one is still a direction: (1e308, 1e-320, 0)
  // is the x axis to double precision; wi = x axis is on the horizon, so f = 0 (a valid answer, not an error).
  const Result mixed = run("eval --model ggx --alpha 0.5 --wo 0,1e-320,1e308 --wi 1e308,1e-320,1e-300");
  ASSERT_EQ(mixed.status, 0) << mixed.out;
  EXPECT_EQ(first_number(mixed.out), 0.0) << mixed.out;
  // Infinite or overflowing-to-infinity components are still refused.
  const Result inf = run("eval --model ggx --wo 0,0,1e309 --wi 0,0,1");
  EXPECT_NE(inf.status, 0);
  EXPECT_NE(inf.out.find("--wo: must be a finite non-zero vector"), std::string::npos) << inf.out;
}

TEST(KilnBrdfCli, LambertAlbedoIsExactlyRho) {
  // Cosine sampling gives every sample the weight ρ exactly, so the estimate is ρ with zero spread.
  const Result r = run("albedo --model lambert --albedo 0.7 --mu 0.3 --samples 1024");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NEAR(first_number(r.out), 0.7, 1e-12);
  EXPECT_NE(r.out.find("std_error 0 "), std::string::npos) << r.out;
}

// A two-lobe material from the lobe flags: weights of two Lamberts is the weighted albedo over π, exactly; layered
// over a black base is its coat alone.
TEST(KilnBrdfCli, TwoLobeMaterialsFromTheLobeFlags) {
  const Result w =
      run("eval --diffuse lambert --diffuse-albedo 0.5 --specular lambert --specular-albedo 0.25 "
          "--combine weights --specular-weight 0.2 --wo 0,0,1 --wi 1,0,1");
  ASSERT_EQ(w.status, 0) << w.out;
  EXPECT_NEAR(first_number(w.out), (0.8 * 0.5 + 0.2 * 0.25) * kiln::kInvPi, 1e-15);
  const Result layered =
      run("eval --diffuse lambert --diffuse-albedo 0 --specular ggx --specular-alpha 0.3 "
          "--wo 0,0,1 --wi 0.2,0,1");
  const Result coat = run("eval --model ggx --alpha 0.3 --wo 0,0,1 --wi 0.2,0,1");
  ASSERT_EQ(layered.status, 0) << layered.out;
  EXPECT_EQ(layered.out, coat.out);
  const Result table = run("table --diffuse lambert --specular ggx --n-mu 2 --n-roughness 2 --samples 256");
  ASSERT_EQ(table.status, 0) << table.out;
  EXPECT_NE(table.out.find("material(layered: "), std::string::npos) << table.out;
  EXPECT_NE(table.out.find("split-sum table of the white specular lobe"), std::string::npos) << table.out;
}

TEST(KilnBrdfCli, TablePrintsBothTables) {
  const Result r = run("table --model ggx --alpha 0.3 --n-mu 4 --n-roughness 3 --samples 256");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("mu,E_r,E_g,E_b"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("roughness,mu,scale,bias"), std::string::npos) << r.out;
  // 4 albedo rows + the average row + 12 split-sum rows, each starting with a digit or "average".
  int data_rows = 0;
  std::istringstream in(r.out);
  for (std::string line; std::getline(in, line);) {
    if (!line.empty() && (std::isdigit(static_cast<unsigned char>(line[0])) || line.rfind("average", 0) == 0)) {
      ++data_rows;
    }
  }
  EXPECT_EQ(data_rows, 4 + 1 + 12);
}

struct BadInput {
  const char* args;
  const char* expected;  // a fragment of the one-line error
};

class KilnBrdfCliErrors : public ::testing::TestWithParam<BadInput> {};

TEST_P(KilnBrdfCliErrors, OneLineErrorAndNonZeroExit) {
  const Result r = run(GetParam().args);
  EXPECT_NE(r.status, 0) << r.out;
  EXPECT_NE(r.status, -1) << "the program crashed: " << r.out;
  EXPECT_NE(r.out.find(GetParam().expected), std::string::npos) << r.out;
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << "expected exactly one line: " << r.out;
}

INSTANTIATE_TEST_SUITE_P(
    Cases, KilnBrdfCliErrors,
    ::testing::Values(BadInput{"eval --model phong --wo 0,0,1 --wi 0,0,1", "--model: expected one of"},
                      BadInput{"eval --model ggx --alpha -0.2 --wo 0,0,1 --wi 0,0,1",
                               "alpha_x: must be in (0, 1], got -0.2"},
                      BadInput{"eval --model ggx --alpha 1.5 --wo 0,0,1 --wi 0,0,1", "must be in (0, 1]"},
                      BadInput{"eval --model ggx --alpha nan --wo 0,0,1 --wi 0,0,1", "got nan"},
                      BadInput{"eval --model lambert --albedo 2 --wo 0,0,1 --wi 0,0,1", "albedo: must be in [0, 1]"},
                      BadInput{"eval --model oren-nayar --sigma 3 --wo 0,0,1 --wi 0,0,1", "sigma: must be in"},
                      BadInput{"eval --model schlick --r 1.5 --wo 0,0,1 --wi 0,0,1", "r: must be in [0, 1]"},
                      BadInput{"eval --model schlick --p -1 --wo 0,0,1 --wi 0,0,1", "p: must be in [0, 1]"},
                      BadInput{"eval --model cook-torrance --eta 0 --wo 0,0,1 --wi 0,0,1", "eta: must be in [0.1, 10]"},
                      BadInput{"eval --model ggx --fresnel fancy --wo 0,0,1 --wi 0,0,1", "--fresnel: expected one of"},
                      BadInput{"eval --model ggx --masking none --wo 0,0,1 --wi 0,0,1", "--masking: expected one of"},
                      BadInput{"eval --model ggx --normalization 2 --wo 0,0,1 --wi 0,0,1", "--normalization: expected"},
                      BadInput{"eval --model ggx --wo 0,0,0 --wi 0,0,1", "--wo: must be a finite non-zero vector"},
                      BadInput{"eval --model ggx --wo 0,0 --wi 0,0,1", "--wo: expected x,y,z"},
                      BadInput{"eval --model ggx --wi 0,0,1", "--wo: missing"},
                      BadInput{"albedo --model ggx --mu 0", "--mu: must be in (0, 1]"},
                      BadInput{"albedo --model ggx --mu 0.5 --samples 0", "--samples: must be a whole number"},
                      BadInput{"table --model ggx --n-mu 100000", "--n-mu: must be a whole number"},
                      BadInput{"eval --model ggx --bogus 1", "unknown option '--bogus'"},
                      BadInput{"frobnicate --model ggx", "unknown command 'frobnicate'"},
                      BadInput{"", "missing command"},
                      BadInput{"eval --diffuse lambert --wo 0,0,1 --wi 0,0,1", "--specular: missing"},
                      BadInput{"eval --model ggx --diffuse lambert --specular ggx --wo 0,0,1 --wi 0,0,1",
                               "give either --model or --diffuse and --specular"},
                      BadInput{"eval --diffuse lambert --specular ggx --specular-alpha 2 --wo 0,0,1 --wi 0,0,1",
                               "specular.alpha_x: must be in (0, 1], got 2"},
                      BadInput{"eval --diffuse lambert --specular ggx --specular-weight 0.3 --wo 0,0,1 --wi 0,0,1",
                               "--specular-weight: applies to --combine weights only"},
                      BadInput{"eval --diffuse lambert --specular ggx --combine mixed --wo 0,0,1 --wi 0,0,1",
                               "--combine: expected layered or weights"},
                      BadInput{"eval --diffuse lambert --specular ggx --alpha 0.3 --wo 0,0,1 --wi 0,0,1",
                               "unknown option '--alpha'"}));

}  // namespace
