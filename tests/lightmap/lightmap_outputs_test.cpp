// The lightmap bake's optional and auxiliary outputs against what they are defined to hold: NAME_radiance.exr = ρE/π,
// NAME_ao.exr (1 in the open; the analytic visibility next to an infinite wall), NAME_sh.exr (the order-1 SH
// projection of a uniform sky over the upper hemisphere), NAME_preview.png (decodes, the lightmap's size) and
// report.json (parses; plan, a monotone curve whose last error is error_estimate, the lightmaps).
#include <gtest/gtest.h>

#include <cctype>
#include <cmath>
#include <cstring>
#include <map>
#include <memory>
#include <stdexcept>
#include <variant>

#include "bakers/image/png.h"
#include "bakers/lightmap/lightmap_bake.h"
#include "bakers/math/constants.h"
#include "bakers/scene/light_sampler.h"
#include "tests/support/test_scenes.h"

namespace kiln::lightmap {
namespace {

using test::exr_output;
using test::lambert_material;
using test::lightmap_input;

// ---- A minimal JSON reader (RFC 8259 values; enough to check report.json's structure, not a general library) ----
struct Json;
using JsonArray = std::vector<Json>;
using JsonObject = std::map<std::string, Json>;
struct Json {
  std::variant<std::nullptr_t, bool, double, std::string, std::shared_ptr<JsonArray>, std::shared_ptr<JsonObject>> v;
  bool is_number() const { return std::holds_alternative<double>(v); }
  double number() const { return std::get<double>(v); }
  const std::string& string() const { return std::get<std::string>(v); }
  const JsonArray& array() const { return *std::get<std::shared_ptr<JsonArray>>(v); }
  const JsonObject& object() const { return *std::get<std::shared_ptr<JsonObject>>(v); }
  bool has(const std::string& key) const { return object().count(key) > 0; }
  const Json& operator[](const std::string& key) const { return object().at(key); }
};

class JsonReader {
 public:
  explicit JsonReader(const std::string& text) : s_(text) {}
  Json document() {
    Json j = value();
    skip();
    if (i_ != s_.size()) fail("trailing characters");
    return j;
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error("report.json: " + what + " at offset " + std::to_string(i_));
  }
  void skip() {
    while (i_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[i_]))) ++i_;
  }
  bool eat(char c) {
    skip();
    if (i_ < s_.size() && s_[i_] == c) return ++i_, true;
    return false;
  }
  void expect(char c) {
    if (!eat(c)) fail(std::string("expected '") + c + "'");
  }
  std::string string_literal() {
    expect('"');
    std::string out;
    while (i_ < s_.size() && s_[i_] != '"') {
      if (s_[i_] == '\\') {
        if (++i_ >= s_.size()) fail("unfinished escape");
        const char e = s_[i_];
        if (e == 'u') {
          if (i_ + 4 >= s_.size()) fail("short \\u escape");
          out += static_cast<char>(std::stoi(s_.substr(i_ + 1, 4), nullptr, 16));  // ASCII control codes only
          i_ += 4;
        } else {
          out += e == 'n' ? '\n' : e == 't' ? '\t' : e;
        }
      } else {
        out += s_[i_];
      }
      ++i_;
    }
    expect('"');
    return out;
  }
  Json value() {
    skip();
    if (i_ >= s_.size()) fail("unexpected end");
    const char c = s_[i_];
    if (c == '"') return Json{string_literal()};
    if (c == '{') {
      ++i_;
      auto obj = std::make_shared<JsonObject>();
      if (!eat('}')) {
        do {
          skip();
          const std::string key = string_literal();
          expect(':');
          (*obj)[key] = value();
        } while (eat(','));
        expect('}');
      }
      return Json{obj};
    }
    if (c == '[') {
      ++i_;
      auto arr = std::make_shared<JsonArray>();
      if (!eat(']')) {
        do arr->push_back(value());
        while (eat(','));
        expect(']');
      }
      return Json{arr};
    }
    for (const auto& [word, j] :
         {std::pair{"true", Json{true}}, std::pair{"false", Json{false}}, std::pair{"null", Json{nullptr}}}) {
      if (s_.compare(i_, std::strlen(word), word) == 0) return i_ += std::strlen(word), j;
    }
    size_t used = 0;
    double d;
    try {
      d = std::stod(s_.substr(i_, 40), &used);
    } catch (const std::exception&) {
      fail("not a JSON value");
    }
    i_ += used;
    return Json{d};
  }
  const std::string& s_;
  size_t i_ = 0;
};

Json parse_json(const std::string& text) { return JsonReader(text).document(); }

// -------------------------------------------------------------------------------------------------------------------

// A 2 m floor of `material` under a uniform sky of radiance 1: E = π at every texel (the furnace of
// lightmap_bake_test).
scene::Scene floor_under_sky(const scene::SceneMaterial& material) {
  scene::Scene s;
  s.materials.push_back(material);
  test::add_floor(s, 2.0, 0);
  s.environment.constant = Rgb{1.0};
  return s;
}

// ρE/π for a Lambertian floor of albedo 0.5 tinted by a base colour, under a uniform sky of radiance 1: E = π exactly
// (the furnace of lightmap_bake_test, zero-variance), so the radiance is ρ·base colour per channel; also checked
// against the bake's own irradiance texel by texel. Float storage: 1e-6 relative.
TEST(LightmapOutputs, RadianceIsRhoTimesIrradianceOverPi) {
  scene::SceneMaterial m = lambert_material("tinted", 0.5);
  m.base_color = Rgb{0.8, 0.6, 0.4};
  const scene::Scene s = floor_under_sky(m);
  LightmapBakeInput in = lightmap_input(s, 16, 0.01);
  in.radiance = true;
  const LightmapBakeResult r = bake_lightmaps(in);
  const image::FloatImage L = exr_output(r, "floor_radiance.exr"), E = exr_output(r, "floor_irradiance.exr");
  ASSERT_EQ(L.channels, 3);
  for (int y = 0; y < 16; ++y) {
    for (int x = 0; x < 16; ++x) {
      for (int c = 0; c < 3; ++c) {
        const double rho = 0.5 * m.base_color[c];
        EXPECT_NEAR(L.at(x, y, c), rho, 1e-6 * rho) << x << "," << y << " channel " << c;
        EXPECT_NEAR(L.at(x, y, c), rho * E.at(x, y, c) / kPi, 1e-6 * rho) << x << "," << y << " channel " << c;
      }
    }
  }
}

// Cosine-weighted visibility within distance d of a floor point at distance x from an infinite wall (taller than d):
// a direction ω (cosine-distributed: its projection (ω_x, ω_z) is uniform on the unit disk) is blocked iff it meets
// the wall within d, i.e. ω_x ≥ x/d. The blocked fraction is the disk's segment beyond a = x/d over the disk's area:
//     AO = 1 − (acos a − a √(1 − a²)) / π,   a = min(1, x/d);   AO → ½ at the foot of the wall.
double ao_next_to_infinite_wall(double x, double d) {
  const double a = std::min(1.0, x / d);
  return 1 - (std::acos(a) - a * std::sqrt(1 - a * a)) / kPi;
}

// AO: exactly 1 on an open plane; next to a wall the analytic value above. The wall runs along z for 4 m, 1.5 m
// high; d = 0.1 × the scene's bounding radius (lightmap_bake.cpp's documented choice) ≈ 0.29 m, so texels with
// |z| < 2 − d see the wall as infinite and tall. Each texel has exactly N = 256 estimates, each the mean over the
// texel's points of a 0/1 visibility: its standard deviation is at most √(p(1 − p)/N) with p the texel's mean AO
// (the variance of a mean of Bernoullis is at most that of one Bernoulli of their mean). Tolerance: 6 of those + 1e-6.
TEST(LightmapOutputs, AmbientOcclusionIsOneInTheOpenAndAnalyticNextToAWall) {
  {
    LightmapBakeInput in = lightmap_input(floor_under_sky(lambert_material("grey", 0.5)), 16, 0.01);
    in.ao = true;
    const image::FloatImage ao = exr_output(bake_lightmaps(in), "floor_ao.exr");
    for (int y = 0; y < 16; ++y) {
      for (int x = 0; x < 16; ++x) EXPECT_EQ(ao.at(x, y, 0), 1.0f) << "open plane texel " << x << "," << y;
    }
  }
  scene::Scene s;
  s.materials.push_back(lambert_material("black", 0.0));
  test::add_floor(s, 4.0, 0, 8);
  test::add_box(s, "wall", {-0.05, 0, -2.0}, {0.05, 1.5, 2.0}, 0);
  s.environment.constant = Rgb{1.0};
  const int W = 32;
  const uint64_t N = 256;
  const double d = 0.1 * scene::scene_bounding_radius(s);
  const auto expected = test::texel_means(
      s, "floor", W, [&](const Vec3& p, const Vec3&) { return ao_next_to_infinite_wall(std::abs(p.x) - 0.05, d); });
  LightmapBakeInput in = lightmap_input(s, W, 0.5);
  in.ao = true;
  in.min_samples = in.max_samples = N;
  const LightmapBakeResult r = bake_lightmaps(in);
  const image::FloatImage ao = exr_output(r, "floor_ao.exr");
  int near_wall = 0;
  for (int y = 0; y < W; ++y) {
    for (int x = 0; x < W; ++x) {
      const double texel = 4.0 / W;
      const double x_lo = -2 + x * texel, x_hi = x_lo + texel, z_lo = -2 + y * texel, z_hi = z_lo + texel;
      if (x_hi > -0.05 - texel && x_lo < 0.05 + texel) continue;  // under the wall or moved by the leak pass
      if (z_lo < -2 + d || z_hi > 2 - d) continue;                // the wall's ends are within reach
      const double p = expected[static_cast<size_t>(y) * W + x];
      if (p < 0.99) ++near_wall;
      EXPECT_NEAR(ao.at(x, y, 0), p, 6 * std::sqrt(p * (1 - p) / N) + 1e-6) << "texel " << x << "," << y;
    }
  }
  EXPECT_GT(near_wall, 40) << "texels within reach of the wall on both sides";
}

// SH of a uniform sky of radiance 1 seen from an upward plane, world axes (+Y up): L_lm = ∫_{y>0} Y_lm dω, so
//   L00  = 0.282095 · 2π,   L1−1 = 0.488603 ∫ y dω = 0.488603 · π,   L10 = L11 = 0 (odd in z, x).
// Per sample both strategies draw ω ~ cos θ/π and weigh it ½ (balance heuristic, equal densities): the L1−1
// estimate is 0.488603 · cos θ · π/cos θ, a constant (exact per texel: float storage, 1e-6). L00, L10 and L11 carry
// 1/cos θ and have infinite (logarithmically divergent) variance, so no per-texel check is meaningful and no σ can be
// computed in advance; the 256 texels are independent estimates, and their mean is checked against the analytic
// value within 6 of its standard errors measured from the texels' own spread (the self-normalised mean, which stays
// well-behaved for such borderline tails), plus float storage.
TEST(LightmapOutputs, ShOfAUniformSkyIsTheHemisphereProjection) {
  LightmapBakeInput in = lightmap_input(floor_under_sky(lambert_material("black", 0.0)), 16, 0.5);
  in.directional = true;
  in.min_samples = in.max_samples = 256;
  const LightmapBakeResult r = bake_lightmaps(in);
  const image::FloatImage sh = exr_output(r, "floor_sh.exr");
  ASSERT_EQ(sh.channels, 12);
  ASSERT_EQ(sh.channel_names.size(), 12u);
  // Channels by name (EXR stores them sorted: L00, L10, L11, L1m1), coefficient c and colour k.
  const char* const layers[4] = {"L00", "L1m1", "L10", "L11"};
  int channel[4][3];
  for (int c = 0; c < 4; ++c) {
    for (int k = 0; k < 3; ++k) channel[c][k] = sh.channel_index(std::string(layers[c]) + "." + "RGB"[k]);
  }
  constexpr double c0 = 0.28209479177387814, c1 = 0.4886025119029199;
  double sum[4][3] = {}, sum_sq[4][3] = {};
  for (int y = 0; y < 16; ++y) {
    for (int x = 0; x < 16; ++x) {
      for (int k = 0; k < 3; ++k) {
        EXPECT_NEAR(sh.at(x, y, channel[1][k]), c1 * kPi, 1e-6 * c1 * kPi) << "L1-1 at " << x << "," << y;
        for (int c = 0; c < 4; ++c) {
          sum[c][k] += sh.at(x, y, channel[c][k]);
          sum_sq[c][k] += std::pow(sh.at(x, y, channel[c][k]), 2);
        }
      }
    }
  }
  const double n = 256, expected[4] = {c0 * 2 * kPi, c1 * kPi, 0.0, 0.0};
  const char* names[4] = {"L00", "L1-1", "L10", "L11"};
  for (int c = 0; c < 4; ++c) {
    for (int k = 0; k < 3; ++k) {
      const double mean = sum[c][k] / n;
      const double standard_error = std::sqrt(std::max(0.0, sum_sq[c][k] / n - mean * mean) / (n - 1));
      EXPECT_NEAR(mean, expected[c], 6 * standard_error + 1e-6) << names[c] << " channel " << k;
    }
  }
  EXPECT_GT(sum_sq[0][0] / n - std::pow(sum[0][0] / n, 2), 0.0) << "L00 is estimated, not constant";

  // The SH error estimate is honest: every texel estimates the same coefficients with the same spread, so the RMS
  // over texels of the actual errors (luminance; of L00 relative to L00, of the L1 vector relative to √3·L00, the
  // larger of the two RMS) measures the per-texel standard error the report claims, within a factor of 2 (the test
  // of the irradiance's estimate, lightmap_bake_test, uses the same factor; 256 texels pin the RMS to ~5 %).
  auto lum = [&](int x, int y, int c) {
    return 0.2126 * sh.at(x, y, channel[c][0]) + 0.7152 * sh.at(x, y, channel[c][1]) +
           0.0722 * sh.at(x, y, channel[c][2]);
  };
  double e00 = 0, e1 = 0;
  for (int y = 0; y < 16; ++y) {
    for (int x = 0; x < 16; ++x) {
      e00 += std::pow((lum(x, y, 0) - expected[0]) / expected[0], 2);
      double d2 = 0;
      for (int c = 1; c < 4; ++c) d2 += std::pow(lum(x, y, c) - expected[c], 2);
      e1 += d2 / (3 * expected[0] * expected[0]);
    }
  }
  const double measured = std::max(std::sqrt(e00 / n), std::sqrt(e1 / n));
  const Json report = parse_json(test::find_output(r, "report.json").bytes);
  const double estimated = report["lightmaps"].array()[0]["sh_error_rms"].number();
  EXPECT_GT(estimated, measured / 2);
  EXPECT_LT(estimated, measured * 2);
}

// The preview decodes as a PNG of the lightmap's size; a uniform irradiance gives a uniform picture, exposed so that
// the median texel is 0.18 (exposure = 0.18/π, exactly as formatted).
TEST(LightmapOutputs, PreviewDecodesWithTheLightmapsSize) {
  LightmapBakeInput in = lightmap_input(floor_under_sky(lambert_material("grey", 0.5)), 24, 0.01);
  in.preview = true;
  const LightmapBakeResult r = bake_lightmaps(in);
  const image::Png8Image png = image::decode_png(test::find_output(r, "floor_preview.png").bytes);
  EXPECT_EQ(png.width, 24);
  EXPECT_EQ(png.height, 24);
  ASSERT_EQ(png.channels, 3);
  for (int y = 0; y < 24; ++y) {
    for (int x = 0; x < 24; ++x) {
      for (int c = 0; c < 3; ++c) EXPECT_EQ(png.at(x, y, c), png.at(0, 0, c)) << x << "," << y;
    }
  }
  EXPECT_GT(png.at(0, 0, 0), 0) << "mid-grey is not black";
  EXPECT_LT(png.at(0, 0, 0), 255) << "mid-grey is not white";
  ASSERT_TRUE(png.metadata.count("kiln:exposure"));
  EXPECT_NEAR(std::stod(png.metadata.at("kiln:exposure")), 0.18 / kPi, 1e-6 * 0.18 / kPi);
  ASSERT_TRUE(png.metadata.count("kiln:exposure_rule"));
  EXPECT_NE(png.metadata.at("kiln:exposure_rule").find("median"), std::string::npos)
      << png.metadata.at("kiln:exposure_rule");
}

// A lightmap more than half of whose valid texels are black (a floor mostly in a box's exact shadow) is exposed by
// the mean of its texels, and the preview says so rather than claiming the median; an all-black one keeps exposure 1.
TEST(LightmapOutputs, PreviewSaysWhichExposureRuleApplied) {
  // All black: no light at all.
  {
    scene::Scene s;
    s.materials.push_back(lambert_material("grey", 0.5));
    test::add_floor(s, 2.0, 0);
    LightmapBakeInput in = lightmap_input(s, 8, 0.1);
    in.preview = true;
    in.max_samples = in.min_samples = 4;
    const LightmapBakeResult r = bake_lightmaps(in);
    const image::Png8Image png = image::decode_png(test::find_output(r, "floor_preview.png").bytes);
    EXPECT_EQ(std::stod(png.metadata.at("kiln:exposure")), 1.0);
    EXPECT_NE(png.metadata.at("kiln:exposure_rule").find("black"), std::string::npos)
        << png.metadata.at("kiln:exposure_rule");
  }
  // A spot's narrow cone lights a disc of radius tan(0.3) ≈ 0.31 on the 2 × 2 floor (under a tenth of it), the rest
  // is black: the median is black.
  {
    scene::Scene s;
    s.materials.push_back(lambert_material("grey", 0.5));
    test::add_floor(s, 2.0, 0);
    scene::Light l;
    l.type = scene::LightShape::spot;
    l.position = {0, 1, 0};
    l.direction = {0, -1, 0};
    l.color = Rgb{1.0};
    l.inner_cone = 0.25;
    l.outer_cone = 0.3;
    s.lights.push_back(l);
    LightmapBakeInput in = lightmap_input(s, 16, 0.1);
    in.preview = true;
    in.max_samples = in.min_samples = 4;
    const LightmapBakeResult r = bake_lightmaps(in);
    const image::Png8Image png = image::decode_png(test::find_output(r, "floor_preview.png").bytes);
    const std::string rule = png.metadata.at("kiln:exposure_rule");
    EXPECT_NE(rule.find("mean"), std::string::npos) << rule;
    EXPECT_NE(png.metadata.at("Description").find("mean"), std::string::npos) << png.metadata.at("Description");
  }
}

// report.json parses and holds the plan, a curve whose seconds and samples never decrease and whose last error is
// error_estimate (numbers are written with round-trip precision: exact equality), and one entry per lightmap.
TEST(LightmapOutputs, ReportJsonHasThePlanCurveAndLightmaps) {
  scene::Scene s;
  s.materials.push_back(lambert_material("grey", 0.5));
  test::add_floor(s, 2.0, 0);
  scene::Light l;
  l.type = scene::LightShape::rect;
  l.position = {0.2, 1.0, -0.1};
  l.u_axis = {0.6, 0, 0};
  l.v_axis = {0, 0, 0.4};
  l.color = Rgb{10.0};
  s.lights.push_back(l);
  LightmapBakeInput in = lightmap_input(s, 16, 0.02);
  in.min_samples = 4;
  const LightmapBakeResult r = bake_lightmaps(in);
  const Json report = parse_json(test::find_output(r, "report.json").bytes);
  for (const char* key : {"plan", "curve", "lightmaps", "error_estimate", "samples", "rays", "seconds"}) {
    EXPECT_TRUE(report.has(key)) << key;
  }
  ASSERT_FALSE(report["plan"].array().empty());
  for (const Json& d : report["plan"].array()) {
    EXPECT_TRUE(d.has("effect") && d.has("enabled") && d.has("reason"));
    EXPECT_FALSE(d["reason"].string().empty()) << d["effect"].string() << " has no reason";
  }
  const JsonArray& curve = report["curve"].array();
  ASSERT_GE(curve.size(), 2u) << "adaptive sampling takes more than one pass here";
  for (size_t i = 1; i < curve.size(); ++i) {
    EXPECT_GE(curve[i]["seconds"].number(), curve[i - 1]["seconds"].number()) << "point " << i;
    EXPECT_GT(curve[i]["samples"].number(), curve[i - 1]["samples"].number()) << "point " << i;
  }
  EXPECT_EQ(curve.back()["error"].number(), report["error_estimate"].number());
  EXPECT_EQ(report["error_estimate"].number(), r.error_estimate);
  EXPECT_EQ(report["samples"].number(), static_cast<double>(r.samples));
  const JsonArray& maps = report["lightmaps"].array();
  ASSERT_EQ(maps.size(), 1u);
  EXPECT_EQ(maps[0]["name"].string(), "floor");
  EXPECT_EQ(maps[0]["resolution"].number(), 16);
  EXPECT_EQ(maps[0]["valid_texels"].number(), 256);
  // The tracer's memory: Embree's (from its monitor) and its own arrays, at least the float vertices it was given.
  EXPECT_GE(report["tracer"]["memory_bytes"].number(), 12.0 * report["tracer"]["triangles"].number());
}

// The memory a lightmap's report states covers what its bake holds: at the least, every sample point's position and
// two normals in double, every texel's RGB sum and
// luminance-square sum, and with AO and SH asked for, one more RGB sum per texel for AO and four RGB sums and four
// luminance-square sums for the SH, in double.
TEST(LightmapOutputs, ReportedMemoryCoversWhatTheBakeHolds) {
  LightmapBakeInput in = lightmap_input(test::floor_under_point_light(0.5, {0, 1, 0}, Rgb{1.0}), 16, 0.1);
  in.min_samples = in.max_samples = 2;
  in.preview = false;
  auto memory = [](const LightmapBakeInput& input) {
    const LightmapBakeResult r = bake_lightmaps(input);
    const Json report = parse_json(test::find_output(r, "report.json").bytes);
    const Json& map = report["lightmaps"].array().at(0);
    const double samples = map["samples_per_texel_point"].number() * map["valid_texels"].number();
    return std::pair{map["memory_bytes"].number(), samples};
  };
  const auto [plain, samples] = memory(in);
  const double texels = 16 * 16;
  EXPECT_GE(plain, texels * 4 * 8 + samples * 9 * 8);
  in.ao = in.directional = true;
  const auto [with_outputs, samples_again] = memory(in);
  EXPECT_EQ(samples_again, samples);
  EXPECT_GE(with_outputs - plain, texels * (3 * 8 + 4 * 3 * 8 + 4 * 8));
}

}  // namespace
}  // namespace kiln::lightmap
