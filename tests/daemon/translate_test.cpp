// The translation layer: job specs in protobuf text format become bakers inputs, and every bad field is refused
// with its path.
#include "daemon/translate.h"

#include <google/protobuf/text_format.h>
#include <gtest/gtest.h>

#include "proto/kiln.pb.h"

namespace kiln::daemon {
namespace {

v1::JobSpec spec_from(const std::string& text) {
  v1::JobSpec spec;
  EXPECT_TRUE(google::protobuf::TextFormat::ParseFromString(text, &spec)) << text;
  return spec;
}

TEST(Translate, GgxWithDefaults) {
  const BakeRequest r = translate(spec_from(R"(name: "x" material { ggx { alpha: 0.25 fresnel: FRESNEL_SCHLICK
                                                f0 { r: 0.04 g: 0.04 b: 0.04 } } })"));
  EXPECT_EQ(r.type, "material");
  EXPECT_EQ(r.material.model.model, brdf::Model::ggx);
  EXPECT_EQ(r.material.model.alpha_x, 0.25);
  EXPECT_EQ(r.material.model.alpha_y, 0.25);
  EXPECT_EQ(brdf::fresnel_mode(r.material.model), brdf::FresnelMode::schlick);
  EXPECT_EQ(r.material.table_mu, 32);
  EXPECT_FALSE(r.material.merl);
}

TEST(Translate, EveryModelTranslates) {
  for (const char* text : {
           "material { lambert { albedo { r: 0.5 g: 0.5 b: 0.5 } } }",
           "material { oren_nayar { sigma: 0.3 interreflection: true } }",
           "material { oren_nayar_simple { sigma: 0.3 } }",
           "material { cook_torrance { alpha: 0.2 eta: 1.33 normalization: NORMALIZATION_PI } }",
           "material { beckmann { alpha_x: 0.1 alpha_y: 0.4 masking: MASKING_HEIGHT_CORRELATED } }",
           "material { schlick { r: 0.2 p: 0.5 } }",
           "material { schlick_double { top { r: 0.1 } bottom { r: 0.9 } } }",
       }) {
    EXPECT_NO_THROW(translate(spec_from(text))) << text;
  }
}

TEST(Translate, SameBakeSameKeyWhateverTheSpelling) {
  // Defaults spelled out or left out, and the name, do not change the key; any setting does.
  const auto a = translate(spec_from("name: \"a\" material { ggx { alpha: 0.3 } }"));
  const auto b = translate(spec_from("name: \"b\" material { ggx { alpha_x: 0.3 alpha_y: 0.3 } table_mu: 32 }"));
  const auto c = translate(spec_from("material { ggx { alpha: 0.31 } }"));
  EXPECT_EQ(cache_key(a, kBakerVersion), cache_key(b, kBakerVersion));
  EXPECT_NE(cache_key(a, kBakerVersion), cache_key(c, kBakerVersion));
  EXPECT_NE(cache_key(a, kBakerVersion), cache_key(a, "another-version"));
}

struct BadSpec {
  const char* text;
  const char* field;
  const char* problem;  // a fragment of the message
};

class TranslateRejects : public ::testing::TestWithParam<BadSpec> {};

TEST_P(TranslateRejects, NamingTheField) {
  try {
    translate(spec_from(GetParam().text));
    FAIL() << "accepted: " << GetParam().text;
  } catch (const InvalidField& e) {
    EXPECT_EQ(e.field(), GetParam().field) << e.what();
    EXPECT_NE(std::string(e.what()).find(GetParam().problem), std::string::npos) << e.what();
  }
}

INSTANTIATE_TEST_SUITE_P(
    Table, TranslateRejects,
    ::testing::Values(
        BadSpec{"material { ggx { alpha: -0.2 } }", "job.material.ggx.alpha", "must be in (0, 1], got -0.2"},
        BadSpec{"material { ggx { alpha: 0 } }", "job.material.ggx.alpha", "must be in (0, 1]"},
        BadSpec{"material { ggx { alpha: nan } }", "job.material.ggx.alpha", "got nan"},
        BadSpec{"material { ggx { alpha: inf } }", "job.material.ggx.alpha", "got inf"},
        BadSpec{"material { ggx { alpha: 0.3 alpha_x: 0.2 alpha_y: 0.2 } }", "job.material.ggx.alpha", "not both"},
        BadSpec{"material { ggx { alpha_x: 0.2 } }", "job.material.ggx.alpha_y", "go together"},
        BadSpec{"material { beckmann { alpha_x: 0.2 alpha_y: 2 } }", "job.material.beckmann.alpha_y", "got 2"},
        BadSpec{"material { ggx { f0 { r: 1.5 } } }", "job.material.ggx.f0.r", "got 1.5"},
        BadSpec{"material { ggx { f0 { g: -1 } } }", "job.material.ggx.f0.g", "got -1"},
        BadSpec{"material { cook_torrance { eta: 0.01 } }", "job.material.cook_torrance.eta", "[0.1, 10]"},
        BadSpec{"material { cook_torrance { eta: 11 } }", "job.material.cook_torrance.eta", "got 11"},
        BadSpec{"material { lambert { albedo { b: 2 } } }", "job.material.lambert.albedo.b", "got 2"},
        BadSpec{"material { oren_nayar { sigma: 2 } }", "job.material.oren_nayar.sigma", "got 2"},
        BadSpec{"material { oren_nayar { sigma: -0.1 } }", "job.material.oren_nayar.sigma", "got -0.1"},
        BadSpec{"material { oren_nayar_simple { interreflection: true } }",
                "job.material.oren_nayar_simple.interreflection", "full model"},
        BadSpec{"material { schlick { r: 1.1 } }", "job.material.schlick.r", "got 1.1"},
        BadSpec{"material { schlick { p: -0.5 } }", "job.material.schlick.p", "got -0.5"},
        BadSpec{"material { schlick { c { r: 3 } } }", "job.material.schlick.c.r", "got 3"},
        BadSpec{"material { schlick_double { bottom { r: 7 } } }", "job.material.schlick_double.bottom.r", "got 7"},
        BadSpec{"material { layered { } }", "job.material.layered", "not supported"},
        BadSpec{"material { }", "job.material", "no model given"},
        BadSpec{"", "job", "no job given"},
        BadSpec{"material { ggx { } table_mu: 0 }", "job.material.table_mu", "got 0"},
        BadSpec{"material { ggx { } table_mu: 100000 }", "job.material.table_mu", "got 100000"},
        BadSpec{"material { ggx { } table_roughness: 1 }", "job.material.table_roughness", "got 1"},
        BadSpec{"quality { samples: 0 } material { ggx { } }", "job.quality.samples", "got 0"},
        BadSpec{"quality { samples: 99999999999 } material { ggx { } }", "job.quality.samples", "got"},
        BadSpec{"quality { target_error: 0 } material { ggx { } }", "job.quality.target_error", "(0, 1]"},
        BadSpec{"quality { target_error: -1 } material { ggx { } }", "job.quality.target_error", "got -1"},
        BadSpec{"quality { time_limit_seconds: 1e9 } material { ggx { } }", "job.quality.time_limit_seconds", "got"},
        BadSpec{"force_effects { key: \"volumes\" value: true } material { ggx { } }",
                "job.force_effects[volumes]", "unknown effect"}));

TEST(Translate, BoundsTheNameAndTheEffects) {
  v1::JobSpec spec = spec_from("material { ggx { } }");
  spec.set_name(std::string(257, 'n'));
  EXPECT_THROW(translate(spec), InvalidField);
  spec.set_name("ok");
  for (int i = 0; i < 65; ++i) (*spec.mutable_force_effects())["e" + std::to_string(i)] = true;
  try {
    translate(spec);
    FAIL();
  } catch (const InvalidField& e) {
    EXPECT_EQ(e.field(), "job.force_effects");
  }
}

TEST(Translate, ForcingMerlOverridesTheFlag) {
  EXPECT_TRUE(translate(spec_from("force_effects { key: \"merl\" value: true } material { ggx { } }")).material.merl);
  EXPECT_FALSE(
      translate(spec_from("force_effects { key: \"merl\" value: false } material { ggx { } merl: true }")).material.merl);
}

}  // namespace
}  // namespace kiln::daemon
