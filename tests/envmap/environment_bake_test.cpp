// The environment bake assembled: a constant environment stays constant in every output.
#include "bakers/envmap/environment_bake.h"

#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "bakers/image/exr.h"
#include "bakers/image/ktx2.h"
#include "bakers/math/constants.h"

namespace kiln::envmap {
namespace {

const material::BakeOutput& output(const EnvironmentBakeResult& r, const std::string& name) {
  for (const auto& o : r.outputs) {
    if (o.name == name) return o;
  }
  throw std::runtime_error("no output " + name);
}

TEST(EnvironmentBake, ConstantEnvironmentIsConstantEverywhere) {
  EnvironmentBakeInput in;
  in.constant = Rgb{0.5, 1.0, 2.0};
  in.size = 16;
  in.irradiance_size = 4;
  in.dfg_size = 4;
  in.dfg_samples = 64;
  const EnvironmentBakeResult r = bake_environment(in);
  // Every level of the specular chain: half floats hold 0.5, 1 and 2 exactly.
  const image::Ktx2Image ktx = image::decode_ktx2(output(r, "specular.ktx2").bytes);
  EXPECT_EQ(ktx.faces, 6);
  EXPECT_EQ(ktx.levels, 3);  // 16, 8, 4
  for (int k = 0; k < ktx.levels; ++k) {
    for (int f = 0; f < 6; ++f) {
      const auto& px = ktx.image(k, f);
      for (size_t i = 0; i < px.size(); i += 4) {
        ASSERT_EQ(px[i], 0.5f);
        ASSERT_EQ(px[i + 1], 1.0f);
        ASSERT_EQ(px[i + 2], 2.0f);
      }
    }
  }
  EXPECT_EQ(ktx.key_values.at("kiln:roughness_per_level"), "0,0.5,1");
  // Irradiance of a constant L is π L (float output: 1e-6 relative).
  const image::FloatImage irr = image::decode_exr(output(r, "irradiance_py.exr").bytes);
  EXPECT_NEAR(irr.at(1, 2, 2), 2.0 * kPi, 2.0 * kPi * 1e-6);
  // SH of a constant: only the constant term, and evaluating it (Y0 · E0, Y0 = 1/(2 sqrt(π))) gives π L at every
  // normal; sh.txt prints round-trip doubles, so 1e-9 is rounding of the projection's sum.
  std::istringstream sh(output(r, "sh.txt").bytes);
  std::string header;
  std::getline(sh, header);
  double e0r, e0g, e0b;
  sh >> e0r >> e0g >> e0b;
  EXPECT_NEAR(e0b * 0.28209479177387814, 2.0 * kPi, 1e-9);
  EXPECT_EQ(r.outputs.size(), 1u + 3 * 6 + 6 + 3);  // ktx2, 3 levels × 6 EXR faces, 6 irradiance, sh, dfg, report
}

TEST(EnvironmentBake, RejectsBadSettings) {
  EnvironmentBakeInput in;
  in.constant = Rgb{1.0};
  in.size = 100;
  EXPECT_NE(validate(in)->find("size"), std::string::npos);
  in.size = 16;
  in.samples = 1;
  EXPECT_NE(validate(in)->find("samples"), std::string::npos);
  in.samples = 64;
  in.constant.reset();
  EXPECT_NE(validate(in)->find("image"), std::string::npos);
  in.image = "not an image";
  EXPECT_THROW(bake_environment(in), std::runtime_error);
}

}  // namespace
}  // namespace kiln::envmap
