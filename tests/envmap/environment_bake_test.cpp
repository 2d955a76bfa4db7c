// The environment bake assembled: a constant environment stays constant in every output.
#include "bakers/envmap/environment_bake.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <sstream>

#include "bakers/envmap/sh.h"
#include "bakers/image/exr.h"
#include "bakers/image/ktx2.h"
#include "bakers/math/constants.h"

namespace kiln::envmap {
namespace {

const bake::BakeOutput& output(const EnvironmentBakeResult& r, const std::string& name) {
  for (const auto& o : r.outputs) {
    if (o.name == name) return o;
  }
  throw std::runtime_error("no output " + name);
}

TEST(EnvironmentBake, ConstantEnvironmentIsConstantEverywhere) {
  for (EnvLobe lobe : {EnvLobe::ggx, EnvLobe::beckmann, EnvLobe::cook_torrance, EnvLobe::schlick}) {
    SCOPED_TRACE(to_string(lobe));
    EnvironmentBakeInput in;
    in.lobe = lobe;
    in.preview = lobe == EnvLobe::ggx;
    in.force_effects["sun_light"] = true;  // forced on with no sun: a no-op, recorded
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
    // ktx2, 3 levels × 6 EXR faces, 6 irradiance, sh, dfg, report (+ preview)
    EXPECT_EQ(r.outputs.size(), 1u + 3 * 6 + 6 + 3 + (in.preview ? 1 : 0));
    EXPECT_EQ(ktx.key_values.at("kiln:lobe"), to_string(lobe));
    EXPECT_FALSE(r.sun_found);
    const std::string report = output(r, "report.json").bytes;
    EXPECT_NE(report.find("no-op"), std::string::npos) << report;
    EXPECT_NE(report.find("\"lobe\": \"" + std::string(to_string(lobe)) + "\""), std::string::npos);
    // The DFG table's masking, in the file and in the report: height-correlated unless the lobe has its own.
    const std::string masking = lobe == EnvLobe::cook_torrance ? "v-groove" : "height-correlated";
    const image::FloatImage dfg = image::decode_exr(output(r, "dfg.exr").bytes);
    EXPECT_EQ(dfg.metadata.at("kiln:masking"), masking);
    EXPECT_NE(report.find("\"dfg_masking\": \"" + masking + "\""), std::string::npos) << report;
    for (const char* c : {"scale", "bias", "energy"})
      EXPECT_EQ(dfg.metadata.count(std::string("kiln:channel.") + c), 1u);
  }
}

// The DFG masking is a setting: separable Smith on request, recorded as such, and darker than the height-correlated
// default where they differ most (grazing μ, high roughness: μ = 0.125, ρ = 0.875, α = 0.77). Read by channel name.
// Measured: energy 0.62 separable against 0.74 height-correlated there; at 4096 samples per entry each has a
// standard error below 3e-3, so a margin of 0.05 is over 10 standard errors and far below the gap.
TEST(EnvironmentBake, DfgMaskingIsASettingRecordedInTheFile) {
  EnvironmentBakeInput in;
  in.constant = Rgb{1.0};
  in.size = 8;
  in.irradiance_size = 2;
  in.dfg_size = 4;
  in.dfg_samples = 4096;
  in.preview = false;
  const EnvironmentBakeResult hc = bake_environment(in);
  in.dfg_masking = brdf::Masking::separable;
  const EnvironmentBakeResult sep = bake_environment(in);
  const image::FloatImage a = image::decode_exr(output(hc, "dfg.exr").bytes);
  const image::FloatImage b = image::decode_exr(output(sep, "dfg.exr").bytes);
  EXPECT_EQ(a.metadata.at("kiln:masking"), "height-correlated");
  EXPECT_EQ(b.metadata.at("kiln:masking"), "separable");
  const float e_hc = a.at(0, 3, a.channel_index("energy")), e_sep = b.at(0, 3, b.channel_index("energy"));
  EXPECT_GT(e_hc, e_sep + 0.05f) << "height-correlated " << e_hc << ", separable " << e_sep;
  // scale + bias = energy in both, channel by name.
  EXPECT_NEAR(b.at(0, 3, b.channel_index("scale")) + b.at(0, 3, b.channel_index("bias")), e_sep, 1e-6);
  in.lobe = EnvLobe::cook_torrance;
  EXPECT_EQ(validate(in)->field(), "dfg_masking");
}

// The six faces of a cube as EXR images.
std::vector<std::string> encode_faces(const Cubemap& cube) {
  std::vector<std::string> faces;
  for (int f = 0; f < kFaceCount; ++f) {
    image::FloatImage img;
    img.width = img.height = cube.size();
    img.channels = 3;
    img.channel_names = {"R", "G", "B"};
    for (const Rgb& c : cube.face(f)) img.pixels.insert(img.pixels.end(), {float(c.r), float(c.g), float(c.b)});
    faces.push_back(image::encode_exr(img));
  }
  return faces;
}

// Test 2 through the whole bake, every lobe: 1 above and 0 below the horizon (six 32² faces; the horizon lies on texel
// edges of the side faces, so the faces hold the step exactly). The irradiance cube is π(1 + sin e)/2 within the
// midpoint rule of the 32² source: 4/n² (irradiance_test's bound, measured 0.44/n²) = 4e-3. The SH irradiance
// equals it exactly in the limit (the order-2 truncation error of this step is zero, sh_test), so only the
// discretisation 10/n² ≈ 1e-2 remains. The specular chain stays in [0, 1] (a convex average) and its level-by-level
// estimate is honest (prefilter_test); here it must have met the target on its checked subset.
TEST(EnvironmentBake, HorizonStepFromFacesGivesTheAnalyticIrradiance) {
  const Cubemap step = cubemap_from(32, [](const Vec3& d) { return d.y > 0 ? Rgb{1.0} : Rgb{0.0}; });
  for (EnvLobe lobe : {EnvLobe::ggx, EnvLobe::beckmann, EnvLobe::cook_torrance, EnvLobe::schlick}) {
    EnvironmentBakeInput in;
    in.faces = encode_faces(step);
    in.lobe = lobe;
    in.size = 32;
    in.levels = 3;
    in.irradiance_size = 8;
    in.dfg_size = 4;
    in.dfg_samples = 64;
    in.preview = false;
    in.target_error = 0.05;
    const EnvironmentBakeResult r = bake_environment(in);
    for (int f = 0; f < 6; ++f) {
      const image::FloatImage irr =
          image::decode_exr(output(r, "irradiance_" + std::string(kFaceNames[f]) + ".exr").bytes);
      for (int y = 0; y < 8; ++y)
        for (int x = 0; x < 8; ++x) {
          const Vec3 n = texel_direction(f, x, y, 8);
          EXPECT_NEAR(irr.at(x, y, 1), kPi * (1.0 + n.y) / 2.0, 4e-3) << to_string(lobe) << " face " << f;
        }
    }
    std::istringstream sh(output(r, "sh.txt").bytes);
    std::string header;
    std::getline(sh, header);
    ShCoefficients e{};
    for (Rgb& c : e) sh >> c.r >> c.g >> c.b;
    for (double elev : {-1.2, -0.5, 0.0, 0.3, 1.0}) {
      const Vec3 n{std::cos(elev) * 0.6, std::sin(elev), std::cos(elev) * 0.8};
      EXPECT_NEAR(evaluate_sh(e, n).g, kPi * (1.0 + std::sin(elev)) / 2.0, 1e-2);
    }
    for (size_t k = 1; k < r.levels.size(); ++k) {
      EXPECT_LE(r.levels[k].checked_error, in.target_error) << k;
      EXPECT_GE(r.levels[k].samples, 16);
    }
    EXPECT_EQ(r.level_samples.size(), 3u);
    EXPECT_FALSE(r.sun_found);
  }
}

// A sun in the faces: found, reported (texels, power, reason), and with sun_light forced off it is not used.
TEST(EnvironmentBake, SunIsFoundReportedAndCanBeForcedOff) {
  Cubemap sky = cubemap_from(16, [](const Vec3& d) { return Rgb{0.5 + 0.5 * std::max(0.0, d.y)}; });
  sky.at(2, 5, 9) = Rgb{1e4};
  EnvironmentBakeInput in;
  in.faces = encode_faces(sky);
  in.size = 16;
  in.irradiance_size = 4;
  in.dfg_size = 4;
  in.dfg_samples = 64;
  in.preview = false;
  in.samples = 64;
  const EnvironmentBakeResult on = bake_environment(in);
  EXPECT_TRUE(on.sun_found);
  EXPECT_EQ(on.sun_texels, 1);
  EXPECT_GT(on.sun_power_fraction, 0.5);
  const std::string report = output(on, "report.json").bytes;
  // The report's layout is the JSON writer's: the values are read back rather than searched for as text.
  const nlohmann::json parsed = nlohmann::json::parse(report);
  EXPECT_EQ(parsed["sun"]["found"], true) << report;
  EXPECT_EQ(parsed["samples"]["per_level"], nlohmann::json({0, 64, 64})) << report;
  for (const char* key : {"\"effect\": \"sun_light\"", "\"stages\"", "\"estimated_peak_bytes\"", "\"conventions\"",
                          "\"sanitized\"", "\"error_estimate\"", "\"color_space\""})
    EXPECT_NE(report.find(key), std::string::npos) << key << "\n" << report;
  in.force_effects["sun_light"] = false;
  const EnvironmentBakeResult off = bake_environment(in);
  EXPECT_FALSE(off.sun_found);
  bool recorded = false;
  for (const auto& e : off.plan_entries) recorded |= e.effect == "sun_light" && e.forced && !e.enabled;
  EXPECT_TRUE(recorded);
}

// Memory is estimated from the headers and refused above 4 GiB, naming the fields: a Radiance header of
// 11584 × 5792 (within the decoder's pixel limit) baked to 2048² needs 11584·5792·60 B + 6·2048²·24 B ≈ 4.6 GB.
TEST(EnvironmentBake, RefusesInputsWhoseMemoryEstimateExceedsTheBound) {
  EnvironmentBakeInput in;
  in.image = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 5792 +X 11584\n";
  in.size = 2048;
  EXPECT_GT(estimate_environment_memory(in, 11584, 5792, false), kMaxEnvironmentMemory);
  try {
    bake_environment(in);
    ADD_FAILURE() << "expected a refusal";
  } catch (const std::invalid_argument& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("size"), std::string::npos) << msg;
    EXPECT_NE(msg.find("image"), std::string::npos) << msg;
    EXPECT_NE(msg.find("4 GiB"), std::string::npos) << msg;
  }
  // The largest cube with a modest image fits: 2048² from 4096 × 2048 (estimate ≈ 2.2 GB).
  EXPECT_LT(estimate_environment_memory(in, 4096, 2048, false), kMaxEnvironmentMemory);
}

TEST(EnvironmentBake, RejectsBadSettings) {
  EnvironmentBakeInput in;
  in.constant = Rgb{1.0};
  in.size = 100;
  EXPECT_NE(std::string(validate(in)->what()).find("size"), std::string::npos);
  in.size = 16;
  in.samples = 1;
  EXPECT_NE(std::string(validate(in)->what()).find("samples"), std::string::npos);
  in.samples = 64;
  in.constant.reset();
  EXPECT_NE(std::string(validate(in)->what()).find("image"), std::string::npos);
  in.image = "not an image";
  EXPECT_THROW(bake_environment(in), std::runtime_error);
  in.force_effects["sunlight"] = true;
  EXPECT_NE(std::string(validate(in)->what()).find("force_effects"), std::string::npos);
  in.force_effects.clear();
  in.target_error = 0;
  EXPECT_NE(std::string(validate(in)->what()).find("target_error"), std::string::npos);
  in.target_error = 0.01;
  in.image.clear();
  in.faces = {"a", "b"};
  EXPECT_NE(std::string(validate(in)->what()).find("faces"), std::string::npos);
}

// Cancelling from the progress callback (here at the end of the sun stage, before the chain) throws BakeCancelled.
TEST(EnvironmentBake, CancelFromProgressThrows) {
  EnvironmentBakeInput in;
  in.constant = Rgb{1.0};
  in.size = 16;
  in.preview = false;
  std::atomic<bool> cancel{false};
  bake::BakeControl control;
  control.cancel = &cancel;
  control.progress = [&](const bake::BakeProgress& p) {
    if (p.stage == "sun") cancel = true;
  };
  EXPECT_THROW(bake_environment(in, control), bake::BakeCancelled);
}

}  // namespace
}  // namespace kiln::envmap
